// The README's GLSL (issue 33): every ```glsl block of the library sections
// ("Using the library" up to "How it works") compiles and links as the body
// of a fragment shader after cdsm.glsl, on the test's GL context. Names a
// block uses come from an HTML comment on the line before its fence
// (<!-- given: vec3 world_pos = vec3(0.0); -->), as for the C++ blocks
// (scripts/readme_snippets.py, compiled by package_consumer).
#include <gtest/gtest.h>

#include <fstream>
#include <sstream>
#include <string>
#include <vector>

#include "cdsm/gl.h"
#include "gl/gl_api.h"
#include "gl_test_util.h"

using namespace cdsm;

namespace {

struct Block {
  int line = 0;  // of the first code line, 1-based
  std::string given, code;
};

std::vector<Block> glsl_blocks(const std::string& readme) {
  std::ifstream in(readme);
  std::vector<std::string> lines;
  for (std::string l; std::getline(in, l);) lines.push_back(l);
  std::vector<Block> out;
  bool in_section = false;
  for (size_t i = 0; i < lines.size(); ++i) {
    if (lines[i].rfind("## Using the library", 0) == 0) in_section = true;
    if (lines[i].rfind("## How it works", 0) == 0) break;
    if (!in_section || lines[i] != "```glsl") continue;
    Block b;
    b.line = int(i) + 2;
    const std::string& before = i > 0 ? lines[i - 1] : std::string();
    const size_t g = before.find("<!-- given:"), e = before.rfind("-->");
    if (g != std::string::npos && e != std::string::npos && e > g) b.given = before.substr(g + 11, e - g - 11);
    for (++i; i < lines.size() && lines[i] != "```"; ++i) b.code += lines[i] + "\n";
    out.push_back(b);
  }
  return out;
}

// The program's link log, or "" when it links.
std::string build_fragment_program(const std::string& source) {
  const char* t = source.c_str();
  const GLuint sh = glCreateShader(GL_FRAGMENT_SHADER);
  glShaderSource(sh, 1, &t, nullptr);
  glCompileShader(sh);
  GLint ok = GL_FALSE;
  char log[8192] = "";
  glGetShaderiv(sh, GL_COMPILE_STATUS, &ok);
  if (!ok) glGetShaderInfoLog(sh, sizeof log, nullptr, log);
  const GLuint p = glCreateProgram();
  glAttachShader(p, sh);
  glLinkProgram(p);
  if (ok) {
    glGetProgramiv(p, GL_LINK_STATUS, &ok);
    if (!ok) glGetProgramInfoLog(p, sizeof log, nullptr, log);
  }
  glDeleteProgram(p);
  glDeleteShader(sh);
  return ok ? std::string() : std::string(log[0] ? log : "failed without a log");
}

class ReadmeGlsl : public test::GlTest {};

TEST_F(ReadmeGlsl, EveryBlockOfTheLibrarySectionsCompiles) {
  const std::string readme = std::string(CDSM_CONTENT_DIR_TEST) + "/../README.md";
  const std::vector<Block> blocks = glsl_blocks(readme);
  ASSERT_FALSE(blocks.empty()) << "no glsl block in " << readme;
  for (const Block& b : blocks) {
    const std::string source = "#version 450\n" + glsl_include() + "layout(location = 0) out vec4 readme_out;\n" +
                               "void main() {\n" + b.given + "\n" + b.code + "readme_out = vec4(1.0);\n}\n";
    EXPECT_EQ(build_fragment_program(source), "") << "README.md:" << b.line;
  }
  // A block that uses a name nobody declared fails: the check can fail.
  EXPECT_NE(build_fragment_program("#version 450\n" + glsl_include() + "void main() { vec3 T = undeclared; }\n"), "");
}

}  // namespace
