//! PLY and OBJ mesh reading and writing (in progress).
