#include "gl/shaders.h"

#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "cdsm/error.h"

namespace cdsm::gl {

namespace detail {
const char* embedded_shader(const char* name);  // generated: shaders_embedded.cpp
}

namespace {

std::string read_file_text(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error(path, "cannot read shader (CDSM_SHADER_DIR is set)");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

}  // namespace

std::string shader_source(const std::string& file) {
  if (const char* dir = std::getenv("CDSM_SHADER_DIR"); dir && *dir) {
    if (file != "cdsm.glsl") return read_file_text(std::string(dir) + "/" + file);
    // cdsm.glsl is kept as parts (cmake/CdsmGlsl.cmake): joined in the
    // build's order, as the embedded copy was.
    std::string text;
    std::istringstream parts(CDSM_GLSL_PARTS);
    for (std::string part; std::getline(parts, part, ',');)
      text += read_file_text(std::string(dir) + "/cdsm/" + part + ".glsl");
    return text;
  }
  if (const char* text = detail::embedded_shader(file.c_str())) return text;
  throw Error("shaders/" + file, "no such embedded shader");
}

namespace {

// Inserts `defines` after the #version line and restores line numbering.
std::string with_defines(const std::string& text, const std::string& defines) {
  if (defines.empty()) return text;
  size_t v = text.find("#version");
  if (v == std::string::npos) return defines + "#line 1\n" + text;
  size_t eol = text.find('\n', v);
  if (eol == std::string::npos) return text + "\n" + defines;
  int version_line = 1;
  for (size_t i = 0; i < eol; ++i) version_line += text[i] == '\n';
  return text.substr(0, eol + 1) + defines + "#line " + std::to_string(version_line + 1) + "\n" + text.substr(eol + 1);
}

std::string shader_log(GLuint shader) {
  GLint n = 0;
  glGetShaderiv(shader, GL_INFO_LOG_LENGTH, &n);
  std::string log(size_t(n > 0 ? n : 1), '\0');
  glGetShaderInfoLog(shader, GLsizei(log.size()), nullptr, log.data());
  return log.c_str();
}

std::string program_log(GLuint program) {
  GLint n = 0;
  glGetProgramiv(program, GL_INFO_LOG_LENGTH, &n);
  std::string log(size_t(n > 0 ? n : 1), '\0');
  glGetProgramInfoLog(program, GLsizei(log.size()), nullptr, log.data());
  return log.c_str();
}

}  // namespace

Program build_program(const std::string& label, std::initializer_list<ShaderStage> stages, const std::string& defines) {
  Program program(label);
  std::vector<Shader> shaders;
  std::string files;
  for (const ShaderStage& st : stages) {
    std::string text = with_defines(shader_source(st.file), defines + st.defines);
    Shader s(st.stage, label + ":" + st.file);
    const char* src = text.c_str();
    CDSM_GL(glShaderSource(s.id(), 1, &src, nullptr));
    CDSM_GL(glCompileShader(s.id()));
    GLint ok = 0;
    CDSM_GL(glGetShaderiv(s.id(), GL_COMPILE_STATUS, &ok));
    if (!ok) throw Error(std::string("shaders/") + st.file, "GLSL compile failed:\n" + shader_log(s.id()));
    CDSM_GL(glAttachShader(program.id(), s.id()));
    files += (files.empty() ? "" : " + ") + std::string(st.file);
    shaders.push_back(std::move(s));
  }
  CDSM_GL(glLinkProgram(program.id()));
  GLint ok = 0;
  CDSM_GL(glGetProgramiv(program.id(), GL_LINK_STATUS, &ok));
  if (!ok) throw Error("shaders/" + files, "GLSL link failed:\n" + program_log(program.id()));
  for (const Shader& s : shaders) CDSM_GL(glDetachShader(program.id(), s.id()));
  return program;
}

}  // namespace cdsm::gl
