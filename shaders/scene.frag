#version 450
// Unlit: output the captured colour as is (see scene.vert for color_source).
#ifdef VULKAN
layout(push_constant) uniform DrawParams {
#else
layout(std140, binding = 0) uniform DrawParams {
#endif
  mat4 clip_from_node;
  vec4 params;
} draw;

#ifdef VULKAN
layout(set = 0, binding = 1) uniform sampler2D base_color;
#else
layout(binding = 1) uniform sampler2D base_color;
#endif

layout(location = 0) in vec2 v_uv;
layout(location = 1) in vec4 v_color;
layout(location = 0) out vec4 out_color;

void main() {
  if (int(draw.params.y) == 1)
    out_color = vec4(texture(base_color, v_uv).rgb, 1.0);
  else
    out_color = v_color;
}
