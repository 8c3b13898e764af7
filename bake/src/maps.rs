//! What the baker takes in: per position, the parameter maps in that
//! position's camera image (an estimate's, read by
//! `matscan_scan::estimate_maps`, or a simulated scan's truth) and the
//! pixels where they are valid.

use matscan_scan::estimate_maps::PositionMaps;
use matscan_scan::raster::MaskRaster;

/// One position's maps and their valid pixels.
#[derive(Debug, Clone, PartialEq)]
pub struct BakeInput {
    /// The maps, named by the position (its camera and lights).
    pub position_maps: PositionMaps,
    /// Valid pixels of the maps; the baker also intersects it with the
    /// mesh's own silhouette in that camera. `None`: the silhouette alone.
    pub mask: Option<MaskRaster>,
}
