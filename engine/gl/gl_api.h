// The one place that includes the OpenGL API, and the checked-call macros.
//
// Function loading: none. GL_GLEXT_PROTOTYPES makes <GL/glcorearb.h> declare
// every core entry point up to 4.6, and libglvnd's libOpenGL.so
// (CMake OpenGL::OpenGL) exports all of them as dispatch stubs that jump
// into whichever vendor library owns the current context (EGL or GLX). So
// no loader (glad, GLEW, epoxy) and no extra dependency: the symbols resolve
// at link time and glvnd routes them at run time.
#pragma once

#ifndef GL_GLEXT_PROTOTYPES
#define GL_GLEXT_PROTOTYPES 1
#endif
#include <GL/glcorearb.h>

#include <string_view>

namespace cdsm::gl {

// Name of a GL error code ("GL_INVALID_OPERATION"), or "0x...." when unknown.
const char* error_name(GLenum error);

namespace detail {
// Drains glGetError(); throws cdsm::Error("file:line", "call failed: GL_...")
// naming the call when any error was pending.
void check_gl(const char* call, const char* file, int line);

template <class T>
T checked(T value, const char* call, const char* file, int line) {
  check_gl(call, file, line);
  return value;
}
}  // namespace detail

// Attaches a debug label to a GL object when the current context has debug
// output on (ContextOptions::debug); no-op otherwise. `identifier` is
// GL_BUFFER, GL_PROGRAM, GL_SHADER, GL_TEXTURE, GL_VERTEX_ARRAY, GL_FRAMEBUFFER...
void label_object(GLenum identifier, GLuint name, std::string_view label);

}  // namespace cdsm::gl

// Every GL call goes through one of these (STYLE.md 8):
//   CDSM_GL(glBindBuffer(GL_ARRAY_BUFFER, b));        // statement
//   GLuint s = CDSM_GLV(glCreateShader(GL_VERTEX_SHADER));  // value
// On error they throw cdsm::Error naming the call, the file and the line.
#define CDSM_GL(call)                                        \
  do {                                                       \
    call;                                                    \
    ::cdsm::gl::detail::check_gl(#call, __FILE__, __LINE__); \
  } while (0)
#define CDSM_GLV(call) ::cdsm::gl::detail::checked((call), #call, __FILE__, __LINE__)
