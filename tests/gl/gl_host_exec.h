// The executor on CPU threads with the cuda executor's GL side
// (cuda/launch.cuh's interop members), for the exec backend's GL hand-over
// code to run in CI: ExecBackend<GlHostExec> is the cuda backend's
// lists_from_gl, write_gl_maps and camera_pass_to_gl, each mapping of a GL
// buffer stood in for by a host copy of it (read with
// glGetNamedBufferSubData before, written back with glNamedBufferSubData
// after: the rasterizer's buffers are immutable storage that GL does not
// map), read and written by the TBB threads as the device's kernels would. It keeps CudaExec's registry of buffer
// objects (name -> generation): a buffer used under a new generation without a release, or released after GL deleted
// it, is a violation.
#pragma once

#include <map>
#include <set>
#include <stdexcept>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "exec/host_exec.h"
#include "gl/gl_api.h"

namespace cdsm::test {

class GlHostExec : public exec::HostExec {
 public:
  static constexpr bool kGlInterop = true;

  bool gl_context_on_device() const { return true; }

  void write_gl_buffers(const GlMapWrite* w, int n, const void* const* src) {
    for (int i = 0; i < n; ++i) {
      see(w[i].gl_buffer, w[i].gl_buffer_generation);
      glNamedBufferSubData(w[i].gl_buffer, GLintptr(w[i].offset), GLsizeiptr(w[i].bytes),
                           static_cast<const unsigned char*>(src[int(w[i].array)]) + w[i].offset);
    }
  }
  template <class F>
  void with_gl_buffer(unsigned name, uint64_t bytes, uint64_t generation, F&& f) {
    see(name, generation);
    staging_.resize(bytes);
    f(static_cast<void*>(staging_.data()));
    glNamedBufferSubData(name, 0, GLsizeiptr(bytes), staging_.data());
  }
  template <class F>
  void with_gl_source(int slot, unsigned name, uint64_t bytes, uint64_t generation, F&& f) {
    see(name, generation);
    ++source_maps;
    if (slot == 0) {
      ++pool_maps;
      pools.insert(name);
    }
    std::vector<unsigned char>& copy = source_[slot];  // both sources mapped at once (lists_from_gl_unchecked)
    copy.resize(bytes);
    glGetNamedBufferSubData(name, 0, GLsizeiptr(bytes), copy.data());
    ++mapped_;
    f(static_cast<const void*>(copy.data()));
    --mapped_;
  }
  // The executor's copy, counted while a source is mapped (pieces of a pool).
  void copy(void* dst, const void* src, size_t bytes) {
    source_copies += mapped_ > 0;
    HostExec::copy(dst, src, bytes);
  }
  void gl_buffer_released(unsigned name) noexcept {
    if (!glIsBuffer(name)) violations.push_back("buffer " + std::to_string(name) + " released after GL deleted it");
    known.erase(name);
    pool_releases += pools.erase(name);
  }

  uint64_t source_maps = 0;            // with_gl_source calls (the rasterizer's buffers mapped)
  uint64_t pool_maps = 0;              // of those, its fragment pool's (one per filling handed over)
  uint64_t source_copies = 0;          // copies made while a source is mapped (lists_from_gl: a pool's pieces)
  uint64_t pool_releases = 0;          // pools released (gl_buffer_released) after they were mapped
  std::map<unsigned, uint64_t> known;  // GL name -> generation, as CudaExec registers them
  std::set<unsigned> pools;            // the pools mapped and not released
  std::vector<std::string> violations;

 private:
  void see(unsigned name, uint64_t generation) {
    if (!glIsBuffer(name)) violations.push_back("buffer " + std::to_string(name) + " is no GL buffer");
    const auto k = known.find(name);
    if (k != known.end() && k->second != generation)
      violations.push_back("buffer " + std::to_string(name) + " used under a new generation, never released");
    known[name] = generation;
  }
  int mapped_ = 0;                        // sources mapped now
  std::vector<unsigned char> staging_;    // the mapped image buffer's stand-in
  std::vector<unsigned char> source_[2];  // the rasterizer's pool's and offsets'
};

}  // namespace cdsm::test
