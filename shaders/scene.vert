#version 450
// One vertex shader for both modes and both backends (Vulkan: compiled to SPIR-V by glslangValidator, which defines
// VULKAN; OpenGL 4.5: compiled from this text by the driver). Unlit: colours pass through unchanged.
// color_source: 0 = vertex colour, 1 = texture sampled per fragment (mesh), 2 = texture sampled at the vertex uv
// (points of a textured mesh without colours).
layout(location = 0) in vec3 in_position;  // node frame, metres
layout(location = 1) in vec2 in_uv;        // (0,0) = top-left texel corner
layout(location = 2) in vec4 in_color;     // RGBA8 normalised

#ifdef VULKAN
layout(push_constant) uniform DrawParams {
#else
layout(std140, binding = 0) uniform DrawParams {
#endif
  mat4 clip_from_node;  // projection * world_to_camera * node_to_world
  vec4 params;          // x = point size px, y = color_source
} draw;

#ifdef VULKAN
layout(set = 0, binding = 1) uniform sampler2D base_color;
#else
layout(binding = 1) uniform sampler2D base_color;
#endif

layout(location = 0) out vec2 v_uv;
layout(location = 1) out vec4 v_color;

void main() {
  gl_Position = draw.clip_from_node * vec4(in_position, 1.0);
  gl_PointSize = draw.params.x;
  v_uv = in_uv;
  if (int(draw.params.y) == 2)
    v_color = vec4(textureLod(base_color, in_uv, 0.0).rgb, 1.0);
  else
    v_color = vec4(in_color.rgb, 1.0);
}
