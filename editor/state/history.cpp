#include "state/history.h"

#include <type_traits>
#include <utility>

namespace cdsm::editor {
namespace {

// `top` now ends where `e` ends (same kind, same key).
void merge(Edit& top, const Edit& e) {
  std::visit(
      [&](auto& t) {
        using T = std::decay_t<decltype(t)>;
        if constexpr (!std::is_same_v<T, change::AddLight> && !std::is_same_v<T, change::RemoveLight>)
          t.after = std::get<T>(e.what).after;
      },
      top.what);
}

}  // namespace

bool History::apply(Document& doc, Edit e, double now) {
  e = rebased(doc, std::move(e));
  if (!e.refused.empty()) {
    refusal_ = e.refused;
    return false;
  }
  if (e.no_op()) return false;
  apply_to(doc.scene, e);
  doc.dirty = true;
  pending_.push_back(e);
  redo_.clear();
  Step* top = undo_.empty() ? nullptr : &undo_.back();
  const bool coalesce = top && !sealed_ && !e.structural() && !top->edit.structural() && top->edit.key == e.key &&
                        top->edit.what.index() == e.what.index() && (gesture_ || now - top->time < kCoalesceSeconds);
  if (coalesce) {
    merge(top->edit, e);
    top->time = now;
    if (top->edit.no_op()) undo_.pop_back();  // dragged back to where it began
  } else {
    undo_.push_back({std::move(e), now});
    if (undo_.size() > kMaxSteps) undo_.erase(undo_.begin());
  }
  sealed_ = false;
  return true;
}

bool History::undo(Document& doc) {
  if (undo_.empty()) return false;
  const Edit inv = rebased(doc, undo_.back().edit.inverse());
  if (!inv.refused.empty()) {  // the document was changed behind the history's back
    refusal_ = inv.refused;
    return false;
  }
  Step step = std::move(undo_.back());
  undo_.pop_back();
  apply_to(doc.scene, inv);
  pending_.push_back(inv);
  redo_.push_back(std::move(step));
  doc.dirty = true;
  sealed_ = true;
  return true;
}

bool History::redo(Document& doc) {
  if (redo_.empty()) return false;
  Edit e = rebased(doc, redo_.back().edit);
  if (!e.refused.empty()) {
    refusal_ = e.refused;
    return false;
  }
  Step step = std::move(redo_.back());
  redo_.pop_back();
  step.edit = std::move(e);
  apply_to(doc.scene, step.edit);
  pending_.push_back(step.edit);
  undo_.push_back(std::move(step));
  doc.dirty = true;
  sealed_ = true;
  return true;
}

void History::begin_gesture() {
  gesture_ = true;
  sealed_ = true;
}

void History::end_gesture() {
  gesture_ = false;
  sealed_ = true;
}

std::vector<Edit> History::take_pending() { return std::exchange(pending_, {}); }

}  // namespace cdsm::editor
