# Imports one glTF/GLB into an empty Blender scene and writes what Blender made of it as JSON, for the
# external-viewer tests (tests/gltf/test_gltf_viewers.cpp). Run headless:
#   blender -b --factory-startup --python tools/blender_gltf_counts.py -- IN.glb OUT.json
# OUT.json: {"ok": true, "meshes", "vertices", "faces", "images", "image_sizes", "cameras", "uv_layers"} or
# {"ok": false, "error": "..."}; exit code 0 either way once the arguments were read, 2 on bad arguments.
import json
import sys

import numpy

# Debian's Blender 3.4 importer calls numpy.bool, which Debian's numpy 1.24 no longer has: the harness's business.
if not hasattr(numpy, "bool"):
    numpy.bool = bool

import bpy  # noqa: E402 (after the numpy fix)

argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
if len(argv) != 2:
    print("usage: blender -b --factory-startup --python blender_gltf_counts.py -- IN.glb OUT.json", file=sys.stderr)
    sys.exit(2)
src, out = argv

bpy.ops.wm.read_factory_settings(use_empty=True)
result = {"ok": False}
try:
    status = bpy.ops.import_scene.gltf(filepath=src)
    if "FINISHED" not in status:
        raise RuntimeError("import returned " + ",".join(sorted(status)))
    meshes = [o for o in bpy.context.scene.objects if o.type == "MESH"]
    images = [i for i in bpy.data.images if i.source in ("FILE", "GENERATED") and i.size[0] > 0]
    result = {
        "ok": True,
        "meshes": len(meshes),
        "vertices": sum(len(o.data.vertices) for o in meshes),
        "faces": sum(len(o.data.polygons) for o in meshes),
        "uv_layers": sum(len(o.data.uv_layers) for o in meshes),
        "images": len(images),
        "image_sizes": [[i.size[0], i.size[1]] for i in images],
        "cameras": len([o for o in bpy.context.scene.objects if o.type == "CAMERA"]),
    }
except Exception as e:  # the importer raises plain exceptions for files it cannot read
    # every line of the message, joined: bpy's operator errors put the cause before a "Location:" line
    lines = [line.strip() for line in str(e).strip().splitlines() if line.strip()]
    result = {"ok": False, "error": " | ".join(lines) if lines else type(e).__name__}
with open(out, "w") as f:
    json.dump(result, f)
