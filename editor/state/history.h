// Undo / redo of the document's edits. Every edit goes through apply():
// it changes the document, is recorded as one undo step (or merged into
// the last one: a slider drag is one step), clears the redo steps, marks
// the document dirty, and queues itself for the shadow system
// (take_pending). Plain C++, no UI; time is a parameter, so tests are
// deterministic.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "state/document.h"
#include "state/edit.h"

namespace cdsm::editor {

class History {
 public:
  // Edits of the same key closer than this (seconds) coalesce.
  static constexpr double kCoalesceSeconds = 0.5;
  // Steps kept; the oldest go first.
  static constexpr size_t kMaxSteps = 1000;

  // Applies `e` (rebased on the document as it is now) and records it. An
  // edit of the same key as the last step coalesces into it — within a
  // gesture (begin_gesture .. end_gesture) whatever the time, else when
  // the last step was applied less than kCoalesceSeconds before — unless
  // the last step was sealed (undo, redo, a gesture's start or end) or is
  // structural. A coalesced step that ends where it began is dropped.
  // Returns false, changing nothing, for a refused edit (last_refusal()
  // says why) or one that changes nothing.
  bool apply(Document& doc, Edit e, double now_seconds);
  bool undo(Document& doc);  // false when there is nothing to undo
  bool redo(Document& doc);
  bool can_undo() const { return !undo_.empty(); }
  bool can_redo() const { return !redo_.empty(); }
  size_t size() const { return undo_.size(); }  // undo steps
  size_t redo_size() const { return redo_.size(); }
  const Edit* last() const { return undo_.empty() ? nullptr : &undo_.back().edit; }  // what undo reverts
  const Edit* next() const { return redo_.empty() ? nullptr : &redo_.back().edit; }  // what redo applies

  // A drag or other continuous interaction: its edits of one key become one step.
  void begin_gesture();
  void end_gesture();
  bool in_gesture() const { return gesture_; }

  // The edits to replay on the shadow system since the last call, in order
  // (each apply, undo and redo adds the change it made to the document).
  std::vector<Edit> take_pending();
  const std::string& last_refusal() const { return refusal_; }

 private:
  struct Step {
    Edit edit;
    double time = 0.0;
  };
  std::vector<Step> undo_, redo_;
  std::vector<Edit> pending_;
  bool gesture_ = false;
  bool sealed_ = true;
  std::string refusal_;
};

}  // namespace cdsm::editor
