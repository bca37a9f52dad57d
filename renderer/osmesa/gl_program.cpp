#include "renderer/osmesa/gl_program.h"

#include <GL/glext.h>

#include <string>

namespace rgbdcast::gl {
namespace {

std::string first_line(std::string log) {
  const size_t nl = log.find('\n');
  return nl == std::string::npos ? log : log.substr(0, nl);
}

Result<GLuint> compile(GLenum type, const char* source, const char* what) {
  GLuint s = glCreateShader(type);
  glShaderSource(s, 1, &source, nullptr);
  glCompileShader(s);
  GLint ok = GL_FALSE;
  glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
  if (ok != GL_TRUE) {
    char log[2048] = {0};
    glGetShaderInfoLog(s, sizeof(log), nullptr, log);
    glDeleteShader(s);
    return make_error(ErrorCode::kInternal,
                      std::string("OpenGL: ") + what + " shader does not compile: " + first_line(log));
  }
  return s;
}

}  // namespace

Result<GLuint> build_program(const char* vertex_source, const char* fragment_source) {
  auto vs = compile(GL_VERTEX_SHADER, vertex_source, "vertex");
  if (!vs) return vs.error();
  auto fs = compile(GL_FRAGMENT_SHADER, fragment_source, "fragment");
  if (!fs) {
    glDeleteShader(vs.value());
    return fs.error();
  }
  GLuint p = glCreateProgram();
  glAttachShader(p, vs.value());
  glAttachShader(p, fs.value());
  glLinkProgram(p);
  glDeleteShader(vs.value());
  glDeleteShader(fs.value());
  GLint ok = GL_FALSE;
  glGetProgramiv(p, GL_LINK_STATUS, &ok);
  if (ok != GL_TRUE) {
    char log[2048] = {0};
    glGetProgramInfoLog(p, sizeof(log), nullptr, log);
    glDeleteProgram(p);
    return make_error(ErrorCode::kInternal, "OpenGL: shader program does not link: " + first_line(log));
  }
  return p;
}

}  // namespace rgbdcast::gl
