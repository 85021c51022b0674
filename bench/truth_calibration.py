#!/usr/bin/env python3
"""Writes the camera of a truth file (stemmap's truth.json, or a sample's ground_truth.json) as an
OpenCV calibration YAML (as from a calibration)."""
import json
import sys

truth = json.load(open(sys.argv[1]))
c = truth["intrinsics"]
with open(sys.argv[2], "w") as f:
    f.write("%YAML:1.0\n---\n")
    width, height = c.get("width", truth.get("width")), c.get("height", truth.get("height"))
    f.write(f"image_width: {width}\nimage_height: {height}\n")
    f.write("camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n")
    f.write(f"   data: [ {c['fx']!r}, 0., {c['cx']!r}, 0., {c['fy']!r}, {c['cy']!r}, 0., 0., 1. ]\n")
    f.write("distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n")
    f.write(f"   data: [ {c.get('k1', 0.0)!r}, {c.get('k2', 0.0)!r}, 0., 0., {c.get('k3', 0.0)!r} ]\n")
