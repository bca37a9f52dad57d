// Frames of the operator page, without three.js (the server view uses them too).
// A mission pose is [x, y, z, qx, qy, qz, qw]: the capture camera's position and rotation in the mission's world, which
// uses OpenCV's axes (x right, y down, z forward). The GLBs and tiles are glTF (y up): a world point p appears at
// C p with C = diag(1, -1, -1) (gltf/gltf_io.h), and the tileset's group is turned back into that frame. A camera's
// glTF rotation is C R C, whose quaternion is (qx, -qy, -qz, qw); a three.js camera looks along its -z with y up,
// which is exactly the glTF camera node's convention, so the same rotation places it.

export function worldToGltf(p) { return [p[0], -p[1], -p[2]]; }

// {position, quaternion} of a three.js camera at the pose's capture camera.
export function poseToGltfCamera(pose) {
  return { position: worldToGltf(pose), quaternion: [pose[3], -pose[4], -pose[5], pose[6]] };
}

// Row-major 3x3 rotation of a quaternion [qx, qy, qz, qw].
export function quatToMat(q) {
  const [x, y, z, w] = q;
  return [[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
          [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
          [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]];
}

// World points (OpenCV frame) of a small frustum of the pose's camera: the apex, then the four corners of its image
// plane at depth `depth_m`, from the keyframe's intrinsics ({width, height, fx, fy, cx, cy}) or a 4:3 default.
export function frustumCorners(pose, intrinsics, depth_m) {
  const r = quatToMat(pose.slice(3, 7));
  const k = intrinsics && intrinsics.fx > 0 ? intrinsics : { width: 640, height: 480, fx: 525, fy: 525, cx: 319.5, cy: 239.5 };
  const at = (u, v) => {
    const c = [(u - k.cx) / k.fx * depth_m, (v - k.cy) / k.fy * depth_m, depth_m];
    return [0, 1, 2].map((i) => pose[i] + r[i][0] * c[0] + r[i][1] * c[1] + r[i][2] * c[2]);
  };
  return [pose.slice(0, 3), at(0, 0), at(k.width, 0), at(k.width, k.height), at(0, k.height)];
}

// Vertical field of view (degrees) of a keyframe's intrinsics, for a view of that camera.
export function verticalFovDeg(intrinsics) {
  if (!intrinsics || !(intrinsics.fy > 0 && intrinsics.height > 0)) return 50;
  return 2 * Math.atan(intrinsics.height / (2 * intrinsics.fy)) * 180 / Math.PI;
}

// The keyframe seqs in capture order (after an outage older keyframes may come with higher seqs).
export function captureOrder(entries) {
  return [...entries.values()].sort((a, b) => a.captured - b.captured || a.seq - b.seq).map((e) => e.seq);
}
