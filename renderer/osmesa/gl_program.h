#pragma once
// Compiles and links the shared GLSL sources of shaders/ (embedded as text) into an OpenGL program.
#include <GL/gl.h>

#include "scene/result.h"

namespace rgbdcast::gl {

// The linked program, or kInternal with the compiler's log (first line) on failure. Needs a current GL context.
Result<GLuint> build_program(const char* vertex_source, const char* fragment_source);

}  // namespace rgbdcast::gl
