#!/usr/bin/env python3
"""Writes the simulated camera of a truth.json as an OpenCV calibration YAML (as from a calibration)."""
import json
import sys

truth = json.load(open(sys.argv[1]))
c = truth["intrinsics"]
with open(sys.argv[2], "w") as f:
    f.write("%YAML:1.0\n---\n")
    f.write(f"image_width: {c['width']}\nimage_height: {c['height']}\n")
    f.write("camera_matrix: !!opencv-matrix\n   rows: 3\n   cols: 3\n   dt: d\n")
    f.write(f"   data: [ {c['fx']!r}, 0., {c['cx']!r}, 0., {c['fy']!r}, {c['cy']!r}, 0., 0., 1. ]\n")
    f.write("distortion_coefficients: !!opencv-matrix\n   rows: 1\n   cols: 5\n   dt: d\n")
    f.write(f"   data: [ {c['k1']!r}, {c['k2']!r}, 0., 0., 0. ]\n")
