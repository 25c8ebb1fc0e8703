// Move-only owners of GL objects (STYLE.md 6). Each is labelled for KHR_debug
// when the current context has debug output on. Destructors never throw;
// delete objects while their context (or one sharing with it) is current.
#pragma once

#include <cstdint>
#include <string>
#include <utility>

#include "gl/gl_api.h"

namespace cdsm::gl {

// Shared move-only handle logic.
template <class Derived>
class Object {
 public:
  Object() = default;
  Object(const Object&) = delete;
  Object& operator=(const Object&) = delete;
  Object(Object&& o) noexcept : id_(std::exchange(o.id_, 0)), label_(std::move(o.label_)) {}
  Object& operator=(Object&& o) noexcept {
    if (this != &o) {
      static_cast<Derived*>(this)->destroy();
      id_ = std::exchange(o.id_, 0);
      label_ = std::move(o.label_);
    }
    return *this;
  }
  GLuint id() const { return id_; }
  explicit operator bool() const { return id_ != 0; }
  // Drops the name without deleting it: for when its context cannot be made
  // current (deleting would hit whatever context is current instead). The
  // object dies with its context.
  void forget() noexcept { id_ = 0; }
  const std::string& label() const { return label_; }

 protected:
  ~Object() = default;
  GLuint id_ = 0;
  std::string label_;
};

// GL buffer work of this thread (a context's work runs on the thread where
// it is current): storage given to buffers and blocking read-backs, each of
// which waits for the GL work queued before it. FrameStats::counters takes
// the difference over a frame.
struct GlCounters {
  uint64_t allocations = 0;
  uint64_t readbacks = 0;
};
GlCounters& thread_gl_counters();

// A buffer with immutable storage that can only grow (so steady-state frames
// allocate nothing). Growing drops the contents.
class Buffer : public Object<Buffer> {
 public:
  Buffer() = default;
  explicit Buffer(std::string label) { label_ = std::move(label); }
  Buffer(Buffer&& o) noexcept : Object(std::move(o)), capacity_(std::exchange(o.capacity_, 0)) {}
  Buffer& operator=(Buffer&& o) noexcept {
    if (this != &o) {
      Object::operator=(std::move(o));
      capacity_ = std::exchange(o.capacity_, 0);
    }
    return *this;
  }
  ~Buffer() { destroy(); }

  // Ensures at least `bytes` of storage; returns true when it (re)allocated.
  bool reserve(uint64_t bytes);
  uint64_t capacity() const { return capacity_; }

  void upload(const void* data, uint64_t bytes, uint64_t offset = 0);
  // Blocks until preceding GL work is done, then copies out.
  void download(void* dst, uint64_t bytes, uint64_t offset = 0) const;
  // Sets `bytes` from `offset` to zero.
  void clear(uint64_t bytes, uint64_t offset = 0);

  void destroy() noexcept;

 private:
  uint64_t capacity_ = 0;
};

class Shader : public Object<Shader> {
 public:
  Shader() = default;
  Shader(GLenum stage, std::string label);
  Shader(Shader&&) noexcept = default;
  Shader& operator=(Shader&&) noexcept = default;
  ~Shader() { destroy(); }
  void destroy() noexcept;
};

class Program : public Object<Program> {
 public:
  Program() = default;
  explicit Program(std::string label);
  Program(Program&&) noexcept = default;
  Program& operator=(Program&&) noexcept = default;
  ~Program() { destroy(); }
  void destroy() noexcept;
};

class VertexArray : public Object<VertexArray> {
 public:
  VertexArray() = default;
  explicit VertexArray(std::string label);
  VertexArray(VertexArray&&) noexcept = default;
  VertexArray& operator=(VertexArray&&) noexcept = default;
  ~VertexArray() { destroy(); }
  void destroy() noexcept;
};

class Framebuffer : public Object<Framebuffer> {
 public:
  Framebuffer() = default;
  explicit Framebuffer(std::string label);
  Framebuffer(Framebuffer&&) noexcept = default;
  Framebuffer& operator=(Framebuffer&&) noexcept = default;
  ~Framebuffer() { destroy(); }
  void destroy() noexcept;
};

}  // namespace cdsm::gl
