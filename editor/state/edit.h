// One edit of the document (STYLE.md 14): a value before and after, so it
// can be applied, undone and replayed on a shadow system; what it
// invalidates there; the key that lets a slider drag coalesce into one undo
// step. Plain values, no UI.
#pragma once

#include <cstddef>
#include <string>
#include <variant>
#include <vector>

#include "cdsm/scene.h"
#include "state/document.h"
#include "state/transform.h"

namespace cdsm::editor {

// An object's interior as one value (Object::interior, sigma, volume).
struct Interior {
  InteriorKind kind = InteriorKind::None;
  Vec3 sigma{0, 0, 0};
  int volume = -1;  // Volume: index into Scene::volumes (kept as given for the other kinds)
};

// The kinds of edit. Indices are into the document's arrays at the time the
// edit applies (undo runs edits in reverse, so they hold).
namespace change {
struct Settings {
  ShadowSettings before, after;
};
struct Camera {
  cdsm::Camera before, after;
  bool maps_follow = false;  // clustered (m > 1) or parallel-split maps when made: their frusta follow the camera
};
struct Background {
  Vec3 before, after;
};
struct Light {
  size_t light = 0;
  cdsm::Light before, after;
};
struct AddLight {
  size_t light = 0;  // inserted here (the end for add_light; undoing a removal puts it back in its place)
  cdsm::Light value;
};
struct RemoveLight {
  size_t light = 0;
  cdsm::Light value;
};  // the light removed
// `caster`: whether the object casts shadows (is in maps) when the edit is made.
struct Transform {
  size_t object = 0;
  Mat4 before, after;
  bool caster = true;
};
struct Surface {
  size_t object = 0;
  SurfaceMaterial before, after;
  bool caster = true;
};
struct ObjectInterior {
  size_t object = 0;
  Interior before, after;
  bool caster = true;
};
struct CastsShadows {
  size_t object = 0;
  bool before = true, after = true;
};
struct Transfer {
  size_t volume = 0;
  std::vector<TransferPoint> before, after;
  int object = -1;  // the object whose interior it is (-1: none)
  bool caster = false;
};
}  // namespace change

struct Edit {
  using Change = std::variant<change::Settings, change::Camera, change::Background, change::Light, change::AddLight,
                              change::RemoveLight, change::Transform, change::Surface, change::ObjectInterior,
                              change::CastsShadows, change::Transfer>;
  Change what;
  // What is edited, for coalescing: "shadows/epsilon", "lights/2/position",
  // "objects/4/transform", ... (JSON pointers of the scene file; several
  // fields joined by '+'). Equal keys within a gesture coalesce; structural
  // edits (add / remove) never do.
  std::string key;
  // Why it cannot apply ("" when it can): an index out of range, a volume
  // another object already holds, a ninth light. History::apply refuses it.
  std::string refused;

  bool structural() const;       // adds or removes a light
  bool no_op() const;            // after equals before (bit for bit), or refused
  Edit inverse() const;          // the edit that undoes this one
  std::string describe() const;  // one line for menus and logs: "shadows/epsilon 0.01 -> 0.02"
};

// The edits the panels make. Each takes the document it will apply to (the
// value before comes from it). None throws: a bad index or value gives an
// edit with `refused` set.
Edit set_settings(const Document& doc, const ShadowSettings& next);
Edit set_camera(const Document& doc, const Camera& next);
Edit set_background(const Document& doc, Vec3 next);
Edit set_light(const Document& doc, size_t light, const Light& next);
Edit add_light(const Document& doc, const Light& light);  // appended; at most kMaxLights
Edit remove_light(const Document& doc, size_t light);
Edit set_transform(const Document& doc, size_t object, const Mat4& next);
Edit set_surface(const Document& doc, size_t object, const SurfaceMaterial& next);
// `volume` matters for kind Volume (no other object may hold it); for the
// other kinds it is kept as given (the panel keeps the object's own). An
// object holding a volume keeps it: every volume fills exactly one object
// (the shadow system and scene files require it), so taking it away is
// refused.
Edit set_interior(const Document& doc, size_t object, InteriorKind kind, Vec3 sigma, int volume);
Edit set_casts_shadows(const Document& doc, size_t object, bool casts);
Edit set_transfer(const Document& doc, size_t volume, const std::vector<TransferPoint>& next);
// Point `i` of `points` dragged on the transfer-function plot by (dd, de):
// its density moves by dd, kept between its neighbours (the order stays
// sorted); its extinction's largest channel by de, not below 0, every
// channel scaled alike (a black point becomes grey). Returns the new points.
std::vector<TransferPoint> drag_transfer_point(std::vector<TransferPoint> points, size_t i, float dd, float de);

// The same change re-targeted at `doc` as it is now: the values before and
// the context (caster, maps following the camera) taken from it; `refused` set when
// it no longer applies. History::apply rebases every edit it is given.
Edit rebased(const Document& doc, Edit e);

// Applies the edit's `after` to the scene (no check: History checks).
void apply_to(Scene& scene, const Edit& e);

// What an edit costs a ShadowSystem (engine/include/cdsm/shadow_system.h's
// table), for the Stats panel and the tests.
struct Invalidation {
  enum class Maps : uint8_t {
    None,    // no map: lookup settings (filtering, bias, receiver, ambient, memory), light colour, intensity
             // or inner cone, a point light's unused direction, the camera with fixed maps, background,
             // a light removed (its maps are freed, the others kept), anything of an object no map holds
             // (but moving one that bounds the scene changes the lights' depth ranges: see Object)
    Lights,  // the maps of lights [light_first, light_last] (indices after the edit): a light moved,
             // turned or its outer cone changed (reason Light), a light added (reason New; the lights
             // after an insertion come back to the system with their maps reused: same views)
    Object,  // the maps holding `object` as a caster before or after the edit (it moved, changed surface,
             // interior or volume, started or stopped casting); with clustered lights, also the maps it
             // enters or leaves. A move that changes the scene's bounds or the caster nearest to a light
             // also changes that light's depth range: then all its maps (reason Frustum)
    All,     // every map (reason Settings): map settings (epsilon, resolution, layout, fixed_layers,
             // chunk_nodes, method, method_param, rgb_maps)
    Views,   // the maps whose frustum or members follow the camera or the clustering (m, d0, parallel
             // splits; the camera when maps follow it): clustered and split lights' maps whose clusters
             // change (reasons Members, Frustum, New); possibly none
  };
  enum class Compile : uint8_t {
    None,       // no recompilation
    Object,     // one object's world-space triangles, a BVH refit (set_transform)
    Structure,  // the geometry arrays of every object (interior changes move media bounds)
    Volume,     // one volume's grid (`volume`), O(its voxels) (set_volume)
  };
  Maps maps = Maps::None;
  Compile compile = Compile::None;
  int light_first = -1, light_last = -1;  // Maps::Lights
  int object = -1;                        // Maps::Object; Compile::Object
  int volume = -1;                        // Compile::Volume
  std::string describe() const;           // "maps of light 1; no compilation"
};

Invalidation invalidation_of(const Edit& e);

}  // namespace cdsm::editor
