// GLSL sources of content/shaders/ and program building.
//
// The .vert/.frag/.comp files in content/shaders/ are the sources of truth
// (editable, readable, diffable); the build embeds them into the library as
// raw string literals (embed_shaders.cmake), so cdsm_gl needs no files at
// run time and no link to the engine's content_dir() (the engine links
// cdsm_gl, not the other way round). While developing shaders, set
// CDSM_SHADER_DIR=/path/to/content/shaders to load them from disk instead
// (cdsm.glsl from its parts in cdsm/, joined as the build joins them).
#pragma once

#include <initializer_list>
#include <string>

#include "gl/gl_objects.h"

namespace cdsm::gl {

struct ShaderStage {
  GLenum stage;              // GL_VERTEX_SHADER, GL_FRAGMENT_SHADER, GL_COMPUTE_SHADER
  const char* file;          // name in content/shaders/, e.g. "fragment_lists.glsl"
  const char* defines = "";  // this stage only, e.g. "#define VERTEX_STAGE 1\n"
};

// Text of content/shaders/<file>: from $CDSM_SHADER_DIR when set, else the
// copy embedded at build time. Throws cdsm::Error when there is neither.
std::string shader_source(const std::string& file);

// Compiles and links the stages into a program labelled `label`. `defines`
// ("#define X 1\n...") go right after each file's #version line (line
// numbers in messages stay those of the file), then the stage's own. Throws cdsm::Error naming the
// file with the compiler's log on failure.
Program build_program(const std::string& label, std::initializer_list<ShaderStage> stages,
                      const std::string& defines = {});

}  // namespace cdsm::gl
