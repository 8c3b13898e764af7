#!/usr/bin/env python3
"""Scale a matscan rig file about the world origin: every camera, flash and
projector position by K, every flash's and the projector's intensity by K^2
(so the object's irradiance stays), intrinsics and orientations unchanged.

It turns a simulated rig at the thesis's 1.5 m into the same rig at another
working distance, for calibration figures at that distance
(`[simulated] rig_from`, docs/results.md). Standard library only.

    python3 tools/scale_rig.py RIG.toml K > SCALED.toml
"""
import re
import sys


def scale_matrix(text, k):
    """Row-major 4x4 after `camera_to_world = [` or `projector_to_world = [`:
    the translation is entries 3, 7 and 11."""

    def one(m):
        nums = [float(x) for x in re.findall(r"[-+0-9.eE]+", m.group(2))]
        if len(nums) != 16:
            raise SystemExit(f"expected 16 numbers after {m.group(1)}")
        for i in (3, 7, 11):
            nums[i] *= k
        rows = [", ".join(repr(v) for v in nums[r * 4:r * 4 + 4]) for r in range(4)]
        return m.group(1) + "[\n  " + ",\n  ".join(rows) + ",\n]"

    return re.sub(r"((?:camera|projector)_to_world = )\[([^\]]*)\]", one, text)


def main():
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    text = open(sys.argv[1], encoding="utf-8").read()
    k = float(sys.argv[2])
    text = scale_matrix(text, k)
    text = re.sub(
        r"^position = \[([^\]]*)\]",
        lambda m: "position = [" + ", ".join(repr(float(x) * k) for x in m.group(1).split(",")) + "]",
        text,
        flags=re.M,
    )
    # Point lights and the projector keep their irradiance at the object;
    # the backlight's intensity is a radiance and stays.
    out, kind = [], None
    for line in text.splitlines():
        m = re.match(r'^kind = "(\w+)"', line)
        if m:
            kind = m.group(1)
        m = re.match(r"^intensity = (.*)$", line)
        if m and kind in ("point", "projector"):
            line = f"intensity = {float(m.group(1)) * k * k!r}"
        out.append(line)
    print("\n".join(out))


if __name__ == "__main__":
    main()
