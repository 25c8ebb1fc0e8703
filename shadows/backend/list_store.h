// Fragment lists an ExecBackend holds for a frame (ListsId): adopted host
// lists kept as they came where the executor's memory is host memory,
// else (and cast or copied lists) in executor arrays. Freed executor
// arrays are kept as spares (a few, capacity intact) for the next lists, so
// a steady frame's lists allocate nothing.
#pragma once

#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

#include "backend/backend.h"
#include "exec/exec.h"

namespace cdsm::exec {

template <class Ex>
class ExecListStore {
 public:
  // One view's lists.
  struct Held {
    explicit Held(Ex& ex) : offsets(ex), fragments(ex), status(ex) {}
    int32_t width = 0, height = 0;
    bool on_host = false;
    FragmentBuffers host;
    ExecArray<uint32_t, Ex> offsets;
    ExecArray<Fragment, Ex> fragments;
    // Lists made without the host reading their count
    // (lists_from_gl_unchecked): `fragments` is their capacity, status[0]
    // their true count and status[1] whether they did not fit, on the
    // executor until a build reads them (then `checked`, and `fragments`
    // cut to the count). `guess_key` names their slot
    // (ShadowBackend::lists_from_gl).
    ExecArray<unsigned long long, Ex> status;
    bool checked = true;
    uint64_t guess_key = 0;
    // The count once checked (the lists' own when never unchecked).
    uint64_t count() const { return on_host ? host.fragments.size() : fragments.size(); }
    FragmentLists lists() {
      if (on_host) return host.lists();
      FragmentLists l;
      l.width = width;
      l.height = height;
      l.offsets = offsets.cspan();
      l.fragments = fragments.span();
      return l;
    }
  };

  explicit ExecListStore(Ex& ex) : ex_(ex) {}

  // New, empty lists in executor memory, to fill and hold(): a spare with
  // room for `offsets` and `fragments` if one has it (else the roomiest).
  std::unique_ptr<Held> make(uint64_t offsets = 0, uint64_t fragments = 0) {
    if (spares_.empty()) return std::make_unique<Held>(ex_);
    size_t pick = 0;
    for (size_t i = 0; i < spares_.size(); ++i) {
      const Held& s = *spares_[i];
      const bool fits = s.offsets.capacity() >= offsets && s.fragments.capacity() >= fragments;
      if (fits || s.fragments.capacity() > spares_[pick]->fragments.capacity()) pick = i;
      if (fits) break;
    }
    std::unique_ptr<Held> h = std::move(spares_[pick]);
    spares_.erase(spares_.begin() + std::ptrdiff_t(pick));
    h->width = h->height = 0;
    h->offsets.resize_discard(0);
    h->fragments.resize_discard(0);
    h->checked = true;
    h->guess_key = 0;
    return h;
  }
  // Lists made but not held (a hand-over that gave up) back to the spares.
  void give_back(std::unique_ptr<Held> h) {
    if (!h || h->on_host) return;
    if (spares_.size() == kSpares) spares_.erase(spares_.begin());
    spares_.push_back(std::move(h));
  }
  // hold() of each, ids[i] h[i]'s; all or nothing (the ones held are freed
  // when one fails).
  void hold_all(std::vector<std::unique_ptr<Held>>& h, ListsId* ids) {
    size_t held = 0;
    try {
      for (; held < h.size(); ++held) ids[held] = hold(std::move(h[held]));
    } catch (...) {
      for (size_t i = 0; i < held; ++i) free(ids[i]);
      throw;
    }
  }
  ListsId hold(std::unique_ptr<Held> h) {
    if (free_.empty()) {
      held_.push_back(std::move(h));
      return ListsId(held_.size() - 1);
    }
    const ListsId id = free_.back();
    free_.pop_back();
    held_[id] = std::move(h);
    return id;
  }
  // Lists `id`; a broken invariant (CDSM_CHECK) when they are not held.
  Held& held(ListsId id, const char* what) const {
    CDSM_CHECK(id < held_.size() && held_[id],
               std::string(what) + ": fragment lists " + std::to_string(id) + " are not held");
    return *held_[id];
  }
  void free(ListsId id) {
    held(id, "free_lists");
    std::unique_ptr<Held> h = std::move(held_[id]);
    free_.push_back(id);
    if (h->on_host) return;                                         // host lists handed over go back to the heap
    if (spares_.size() == kSpares) spares_.erase(spares_.begin());  // the oldest goes
    spares_.push_back(std::move(h));
  }

  // Host lists handed over: moved in over host memory, else uploaded.
  ListsId adopt(FragmentBuffers&& lists) {
    check(lists.width, lists.height, lists.offsets.size(), lists.fragments.size(), "adopt_lists");
    auto h = make();
    h->width = lists.width;
    h->height = lists.height;
    if constexpr (Ex::kHostMemory) {
      h->host = std::move(lists);  // moved in: no copy
      h->on_host = true;
    } else {
      h->offsets.assign(lists.offsets);
      h->fragments.assign(lists.fragments);
    }
    return hold(std::move(h));
  }

  // A copy made on the executor.
  ListsId copy(ListsId id) {
    const FragmentLists from = held(id, "copy_lists").lists();
    auto h = make(from.offsets.size(), from.fragments.size());
    h->width = from.width;
    h->height = from.height;
    h->offsets.resize_discard(from.offsets.size());
    h->fragments.resize_discard(from.fragments.size());
    if (from.offsets.size()) ex_.copy(h->offsets.data(), from.offsets.data(), from.offsets.size() * sizeof(uint32_t));
    if (from.fragments.size())
      ex_.copy(h->fragments.data(), from.fragments.data(), from.fragments.size() * sizeof(Fragment));
    const Held& src = held(id, "copy_lists");
    if (!src.checked) {  // a copy of lists not yet checked is checked by its own build
      h->status.resize_discard(2);
      ex_.copy(h->status.data(), src.status.data(), 2 * sizeof(unsigned long long));
      h->checked = false;
      h->guess_key = src.guess_key;
    }
    return hold(std::move(h));
  }

  // Downloads lists `id` into `out` (host memory).
  void read(ListsId id, FragmentBuffers& out) const {
    const FragmentLists l = held(id, "read_lists").lists();
    out.width = l.width;
    out.height = l.height;
    out.offsets.resize(l.offsets.size());
    out.fragments.resize(l.fragments.size());
    if (l.offsets.size()) ex_.download(out.offsets.data(), l.offsets.data(), l.offsets.size() * sizeof(uint32_t));
    if (l.fragments.size())
      ex_.download(out.fragments.data(), l.fragments.data(), l.fragments.size() * sizeof(Fragment));
  }

  static uint64_t bytes(const FragmentLists& l) {
    return l.offsets.size() * sizeof(uint32_t) + l.fragments.size() * sizeof(Fragment);
  }
  // Every held lists' count and bytes (MapStoreStats).
  void add_stats(MapStoreStats& s) const {
    for (const std::unique_ptr<Held>& h : held_)
      if (h) {
        ++s.lists;
        s.list_bytes += bytes(h->lists());
      }
    for (const std::unique_ptr<Held>& h : spares_)
      s.spare_list_bytes += h->offsets.capacity() * sizeof(uint32_t) + h->fragments.capacity() * sizeof(Fragment);
  }

  // Lists of width x height pixels: width * height + 1 offsets, the last the
  // fragment count (the only entry checked here: the rest is the producer's).
  static void check(int32_t width, int32_t height, uint64_t offsets, uint64_t fragments, const char* what) {
    if (width < 0 || height < 0 || offsets != uint64_t(width) * uint64_t(height) + 1)
      throw std::invalid_argument(std::string(what) + ": " + std::to_string(offsets) + " offsets for lists of " +
                                  std::to_string(width) + "x" + std::to_string(height) +
                                  " pixels (width * height + 1 expected)");
    if (fragments > 0xffffffffull) throw std::length_error(std::string(what) + ": more than 2^32-1 fragments");
  }

 private:
  Ex& ex_;
  std::vector<std::unique_ptr<Held>> held_;  // by ListsId (null: free)
  std::vector<ListsId> free_;
  static constexpr size_t kSpares = 8;         // freed lists kept for reuse, at most
  std::vector<std::unique_ptr<Held>> spares_;  // oldest first
};

}  // namespace cdsm::exec
