#!/usr/bin/python3
"""Packs raw images into a ROS 1 bag for the rosbag input tests (Debian's python3-rosbag and python3-sensor-msgs).

The test decides every pixel (it writes the raw buffers); this script only wraps them in sensor_msgs messages, so the
bag holds exactly what the test compares against. Usage: write_test_bag.py MANIFEST.json OUT.bag

MANIFEST: {"camera_info": {"topic", "stamp", "width", "height", "K": [9], "D": [..], "distortion_model"} (optional),
           "images": [{"topic", "stamp", "width", "height", "encoding", "step", "file"}],
           "compression": "none" | "bz2" | "lz4" (optional, chunk compression)}
Messages are written in stamp order with the bag time equal to the header stamp.
"""
import json
import sys

import genpy
import rosbag
from sensor_msgs.msg import CameraInfo, Image


def stamp(t):
    return genpy.Time.from_sec(t)


def main():
    manifest_path, out_path = sys.argv[1], sys.argv[2]
    with open(manifest_path) as f:
        manifest = json.load(f)
    records = []
    ci = manifest.get("camera_info")
    if ci:
        msg = CameraInfo()
        msg.header.stamp = stamp(ci["stamp"])
        msg.header.frame_id = "openni_rgb_optical_frame"
        msg.width, msg.height = ci["width"], ci["height"]
        msg.K = ci["K"]
        msg.D = ci["D"]
        msg.distortion_model = ci.get("distortion_model", "plumb_bob")
        msg.R = [1, 0, 0, 0, 1, 0, 0, 0, 1]
        k = ci["K"]
        msg.P = [k[0], 0, k[2], 0, 0, k[4], k[5], 0, 0, 0, 1, 0]
        records.append((ci["stamp"], ci["topic"], msg))
    for im in manifest["images"]:
        msg = Image()
        msg.header.stamp = stamp(im["stamp"])
        msg.header.frame_id = "openni_camera"
        msg.width, msg.height = im["width"], im["height"]
        msg.encoding = im["encoding"]
        msg.is_bigendian = 0
        msg.step = im["step"]
        with open(im["file"], "rb") as f:
            msg.data = f.read()
        records.append((im["stamp"], im["topic"], msg))
    records.sort(key=lambda r: r[0])
    with rosbag.Bag(out_path, "w", compression=manifest.get("compression", "none")) as bag:
        for t, topic, msg in records:
            bag.write(topic, msg, stamp(t))


if __name__ == "__main__":
    main()
