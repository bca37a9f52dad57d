#!/usr/bin/env bash
# Writes the seed corpus of the multipart fuzz target, fuzz/corpus/multipart/ (run by hand when the upload's parts
# change; the output is committed), from the frame_upload seeds (u32 intrinsics length, u32 colour length, the
# intrinsics, colour and depth bytes): each seed is a boundary line, then a multipart/form-data body as clients send
# it (curl -F): the three parts in two orders, with and without filename and Content-Type, a repeated part, a part
# missing, and a preamble and epilogue.
set -euo pipefail
cd "$(dirname "$0")/.."
/usr/bin/python3 - <<'PY'
import os, struct
src, out = "fuzz/corpus/frame_upload", "fuzz/corpus/multipart"
os.makedirs(out, exist_ok=True)
def parts_of(path):
    b = open(path, "rb").read()
    nj, nc = struct.unpack("<II", b[:8])
    return {"intrinsics": b[8:8 + nj], "color": b[8 + nj:8 + nj + nc], "depth": b[8 + nj + nc:]}
def body(boundary, parts, files=True, pre=b"", post=b""):
    out = pre
    for name, data in parts:
        out += b"--" + boundary + b"\r\nContent-Disposition: form-data; name=\"" + name.encode() + b"\""
        if files and name != "intrinsics":
            out += b"; filename=\"" + name.encode() + b".png\"\r\nContent-Type: image/png"
        out += b"\r\n\r\n" + data + b"\r\n"
    return out + b"--" + boundary + b"--\r\n" + post
def seed(name, boundary, parts, **kw):
    open(f"{out}/{name}", "wb").write(boundary + b"\n" + body(boundary, parts, **kw))
png, jpg = parts_of(f"{src}/frame_png"), parts_of(f"{src}/frame_jpg")
order = ["color", "depth", "intrinsics"]
seed("png_curl", b"------------------------d74496d66958873e", [(n, png[n]) for n in order])
seed("jpg_reordered_no_filenames", b"xYzZY", [(n, jpg[n]) for n in reversed(order)], files=False)
seed("repeated_part", b"b", [(n, png[n]) for n in order + ["color"]])
seed("missing_intrinsics", b"--boundary--", [(n, png[n]) for n in order[:2]])
seed("preamble_epilogue", b"0123456789", [(n, jpg[n]) for n in order], pre=b"preamble\r\n", post=b"epilogue")
PY
ls -l fuzz/corpus/multipart
