#include "gl/prefix_sum.h"

#include <algorithm>
#include <string>

#include "cdsm/error.h"
#include "gl/shaders.h"

namespace cdsm::gl {

namespace {
enum Binding : GLuint { kIn = 0, kOut = 1, kSums = 2, kStatus = 3 };
constexpr GLint kUniformN = 0;

uint64_t div_up(uint64_t a, uint64_t b) { return (a + b - 1) / b; }
}  // namespace

PrefixSum::PrefixSum(Context& context)
    : context_(context),
      scan_(build_program("cdsm.prefix_sum.scan_blocks", {{GL_COMPUTE_SHADER, "prefix_sum.comp"}},
                          "#define SCAN_BLOCKS 1\n")),
      add_(build_program("cdsm.prefix_sum.add_offsets", {{GL_COMPUTE_SHADER, "prefix_sum.comp"}},
                         "#define ADD_OFFSETS 1\n")),
      status_("cdsm.prefix_sum.status") {
  status_.reserve(4);
}

void PrefixSum::dispatch_blocks(uint64_t blocks) {
  const Limits& lim = context_.limits();
  uint64_t gx = std::min<uint64_t>(blocks, uint64_t(lim.max_compute_groups_x));
  uint64_t gy = div_up(blocks, gx);
  if (gy > uint64_t(lim.max_compute_groups_y))
    throw Error("gl::PrefixSum", std::to_string(blocks) + " workgroups exceed the dispatch limits");
  CDSM_GL(glDispatchCompute(GLuint(gx), GLuint(gy), 1));
  CDSM_GL(glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT));
}

void PrefixSum::exclusive_scan(const Buffer& in, Buffer& out, uint64_t n) {
  if (n > 0xffffffffull) throw Error("gl::PrefixSum", "more than 2^32-1 values");
  if (out.capacity() < (n + 1) * 4 || in.capacity() < n * 4)
    throw Error("gl::PrefixSum", "buffers too small for " + std::to_string(n) + " values");
  status_.clear(4);
  if (n == 0) {
    out.clear(4);
    return;
  }
  // Level sizes: sizes[l] values are scanned by pass l, which writes
  // sizes[l+1] block sums into levels_[l]; the last pass has one block.
  std::vector<uint64_t> sizes{n};
  do {
    sizes.push_back(div_up(sizes.back(), kBlock));
  } while (sizes.back() > 1);
  size_t passes = sizes.size() - 1;
  while (levels_.size() < passes) levels_.emplace_back("cdsm.prefix_sum.level" + std::to_string(levels_.size()));
  for (size_t l = 0; l < passes; ++l) levels_[l].reserve(sizes[l + 1] * 4);

  CDSM_GL(glMemoryBarrier(GL_SHADER_STORAGE_BARRIER_BIT));  // `in` may come from a shader
  CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kStatus, status_.id()));
  CDSM_GL(glUseProgram(scan_.id()));
  for (size_t l = 0; l < passes; ++l) {
    GLuint src = l == 0 ? in.id() : levels_[l - 1].id();
    GLuint dst = l == 0 ? out.id() : levels_[l - 1].id();
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kIn, src));
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kOut, dst));
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kSums, levels_[l].id()));
    CDSM_GL(glProgramUniform1ui(scan_.id(), kUniformN, GLuint(sizes[l])));
    dispatch_blocks(sizes[l + 1]);
  }
  CDSM_GL(glUseProgram(add_.id()));
  for (size_t l = passes - 1; l-- > 0;) {
    GLuint dst = l == 0 ? out.id() : levels_[l - 1].id();
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kOut, dst));
    CDSM_GL(glBindBufferBase(GL_SHADER_STORAGE_BUFFER, kSums, levels_[l].id()));
    CDSM_GL(glProgramUniform1ui(add_.id(), kUniformN, GLuint(sizes[l])));
    dispatch_blocks(sizes[l + 1]);
  }
  CDSM_GL(glUseProgram(0));
  // The last pass's single block sum is the total: out[n].
  CDSM_GL(glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT));
  CDSM_GL(glCopyNamedBufferSubData(levels_[passes - 1].id(), out.id(), 0, GLintptr(n * 4), 4));
}

bool PrefixSum::overflowed() {
  CDSM_GL(glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT));
  uint32_t flag = 0;
  status_.download(&flag, 4);
  return flag != 0;
}

void PrefixSum::write_overflow_flag(Buffer& out, uint64_t at) {
  if (out.capacity() < (at + 1) * 4)
    throw Error("gl::PrefixSum", "no room for the overflow flag at value " + std::to_string(at));
  CDSM_GL(glMemoryBarrier(GL_BUFFER_UPDATE_BARRIER_BIT));
  CDSM_GL(glCopyNamedBufferSubData(status_.id(), out.id(), 0, GLintptr(at * 4), 4));
}

void PrefixSum::forget() noexcept {
  scan_.forget();
  add_.forget();
  for (Buffer& b : levels_) b.forget();
  status_.forget();
}

}  // namespace cdsm::gl
