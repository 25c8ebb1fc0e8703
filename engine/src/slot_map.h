// Handles that cost O(1) (Filament's Entity is the model): a handle's id is
// a slot index and that slot's generation. The slot holds the position of
// the thing in the system's dense arrays (scene.objects, scene.lights, ...),
// which stay in handle order; removing a thing frees its slot and bumps the
// slot's generation, so an old handle to it is recognised as stale, never
// taken for the thing that reuses the slot.
//
//   id = generation << 32 | (slot + 1)       (0 is "none": slot + 1 >= 1)
#pragma once

#include <cstdint>
#include <cstring>
#include <string>
#include <vector>

namespace cdsm {

class SlotMap {
 public:
  enum class Lookup { Found, Removed, Foreign };

  // A new id whose thing lies at `position`.
  uint64_t insert(uint32_t position) {
    uint32_t slot;
    if (!free_.empty()) {
      slot = free_.back();
      free_.pop_back();
    } else {
      slot = uint32_t(slots_.size());
      slots_.push_back({});
    }
    slots_[slot].position = position;
    slots_[slot].live = true;
    ++live_;
    return id_of(slot, slots_[slot].generation);
  }

  // Where the thing `id` names lies, or why it names none: Removed (a
  // handle this map gave out, to a thing since removed) or Foreign (never
  // given out here). O(1).
  Lookup find(uint64_t id, uint32_t* position) const {
    const uint64_t low = id & 0xffffffffu;
    if (low == 0 || low > slots_.size()) return Lookup::Foreign;
    const Slot& s = slots_[low - 1];
    const uint32_t generation = uint32_t(id >> 32);
    if (s.live && s.generation == generation) {
      *position = s.position;
      return Lookup::Found;
    }
    return generation < s.generation || (!s.live && generation == s.generation) ? Lookup::Removed : Lookup::Foreign;
  }

  // The thing `id` names moved to `position` (the dense arrays shifted).
  void move(uint64_t id, uint32_t position) { slots_[slot_of(id)].position = position; }

  // Frees `id`'s slot (it must be live). A slot whose generation would wrap
  // is retired instead of reused, so an id is never given out twice.
  void erase(uint64_t id) {
    const uint32_t slot = slot_of(id);
    Slot& s = slots_[slot];
    s.live = false;
    --live_;
    if (s.generation == 0xffffffffu) return;
    ++s.generation;
    free_.push_back(slot);
  }

  size_t live() const { return live_; }

 private:
  struct Slot {
    uint32_t generation = 0;
    uint32_t position = 0;
    bool live = false;
  };
  static uint64_t id_of(uint32_t slot, uint32_t generation) {
    return uint64_t(generation) << 32 | (uint64_t(slot) + 1);
  }
  static uint32_t slot_of(uint64_t id) { return uint32_t((id & 0xffffffffu) - 1); }

  std::vector<Slot> slots_;
  std::vector<uint32_t> free_;
  size_t live_ = 0;
};

// "object handle 4294967297 (slot 0, generation 1): <why>" for an error.
inline std::string describe_handle(const char* kind, uint64_t id, SlotMap::Lookup why) {
  std::string s = std::string(kind) + " handle " + std::to_string(id);
  if ((id & 0xffffffffu) != 0)
    s += " (slot " + std::to_string((id & 0xffffffffu) - 1) + ", generation " + std::to_string(id >> 32) + ")";
  const std::string a = std::string(std::strchr("aeiou", kind[0]) ? "an " : "a ") + kind;
  s += why == SlotMap::Lookup::Removed ? " names " + a + " removed from this system"
                                       : " does not name " + a + " of this system";
  return s;
}

}  // namespace cdsm
