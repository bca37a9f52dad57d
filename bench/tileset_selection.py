"""Which tiles of a 3D Tiles tileset a client selects for one camera: the standard screen-space-error traversal.

A tile's screen-space error is sse = geometricError * viewport_height / (2 * distance * tan(fovy / 2)) pixels, with
distance from the camera to the tile's bounding box (0 inside it, which refines it). A tile whose sse exceeds the
limit and that has children is refined (REPLACE: its children are drawn instead of it); otherwise its content is
drawn. Only box volumes are understood (what rgbdcast writes); no frustum culling, so the camera must see the whole
tileset (an overview). Pure functions over the parsed tileset.json and a camera in the tileset's frame.
"""
import math


def _sub(a, b):
    return [a[i] - b[i] for i in range(3)]


def _dot(a, b):
    return sum(a[i] * b[i] for i in range(3))


def box_distance(box, eye):
    """Distance in metres from `eye` to a 3D Tiles box [cx, cy, cz, ux, uy, uz, vx, vy, vz, wx, wy, wz] (0 inside)."""
    d = _sub(eye, box[0:3])
    outside2 = 0.0
    for axis in (box[3:6], box[6:9], box[9:12]):
        half = math.sqrt(_dot(axis, axis))
        if half == 0.0:
            continue
        along = abs(_dot(d, axis)) / half
        if along > half:
            outside2 += (along - half) ** 2
    return math.sqrt(outside2)


def screen_space_error(tile, eye, height_px, fovy_rad):
    distance = box_distance(tile["boundingVolume"]["box"], eye)
    if distance <= 1e-9:
        return math.inf
    return tile["geometricError"] * height_px / (2.0 * distance * math.tan(fovy_rad / 2.0))


def select_contents(tileset, eye, height_px, fovy_rad, max_sse_px=16.0):
    """The content URIs drawn for a camera at `eye` (tileset frame): a list, in traversal order."""
    selected = []

    def visit(tile):
        children = tile.get("children") or []
        if children and screen_space_error(tile, eye, height_px, fovy_rad) > max_sse_px:
            for child in children:
                visit(child)
            return
        content = tile.get("content")
        if content and "uri" in content:
            selected.append(content["uri"])

    visit(tileset["root"])
    return selected


def world_to_tileset(p):
    """rgbdcast's mission world (OpenCV axes: x right, y down, z forward) to its tileset's z-up frame (x, z, -y)."""
    return [p[0], p[2], -p[1]]
