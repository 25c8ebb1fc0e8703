// Field tables (cdsm/fields.h): a field added to a struct's table reaches
// every consumer. A test struct with its own table goes through the generic
// consumers (reader, comparison, what-changed, effects, hash); the scene's
// own settings table goes through the writer and the range checks, field by
// field, so a field added to ShadowSettings' table is covered here without
// a line of this file changing.
#include <gtest/gtest.h>

#include <cmath>
#include <string>
#include <type_traits>

#include "cdsm/error.h"
#include "cdsm/fields.h"
#include "cdsm/method_params.h"
#include "cdsm/procedural.h"
#include "cdsm/scene_io.h"
#include "json_reader.h"
#include "unit_util.h"

namespace cdsm {

struct TestSettings {
  float a = 0.5f;
  int32_t b = 3;
  bool c = false;
  Vec3 d{0.1f, 0.2f, 0.3f};
  DsmLayout e = DsmLayout::Packed;
  float added = 7.0f;  // the field "added" to the table below
};

template <>
struct FieldTable<TestSettings> {
  using S = TestSettings;
  static constexpr auto fields = std::make_tuple(
      field("a", &S::a, 0.0, 1.0, kAffectsMaps, ""), field("b", &S::b, 1, 8, kAffectsClusters, ""),
      field("c", &S::c, 0, 1, kAffectsLookup, ""), field("d", &S::d, 0.0, 1.0, kAffectsLookup, ""),
      field("e", &S::e, 0, 0, kAffectsMaps, ""), field("added", &S::added, 0.0, 10.0, kAffectsPlan, ""));
};

namespace {

using Hasher = Fnv1a;

template <class S>
uint64_t hash_of(const S& s, uint32_t bits) {
  Hasher h;
  hash_fields(h, s, bits);
  return h.h;
}

TEST(Fields, AFieldInTheTableReachesEveryGenericConsumer) {
  const TestSettings a;
  TestSettings b = a;
  b.added = 8.0f;
  EXPECT_TRUE(same_fields(a, a));
  EXPECT_FALSE(same_fields(a, b)) << "comparison (what decides an edit reached the system)";
  EXPECT_EQ(changed_fields(a, b), "added") << "the editor's what-changed";
  EXPECT_EQ(changed_effects(a, b), uint32_t(kAffectsPlan)) << "what the change makes stale";
  EXPECT_NE(hash_of(a, kAffectsPlan), hash_of(b, kAffectsPlan)) << "hash over the fields it affects";
  EXPECT_EQ(hash_of(a, kAffectsMaps), hash_of(b, kAffectsMaps)) << "not in the hash of what it does not affect";

  // The reader: the key is read and known; a key not in the table is an error.
  const nlohmann::json j = nlohmann::json::parse(R"({"a": 0.25, "added": 9, "e": "chunked", "d": [1, 0, 0]})");
  TestSettings r;
  JsonNode(j, "test.json", "").read_fields(r);
  EXPECT_EQ(r.added, 9.0f);
  EXPECT_EQ(r.a, 0.25f);
  EXPECT_EQ(r.e, DsmLayout::Chunked);
  EXPECT_EQ(r.b, 3) << "absent: the struct's default";
  const nlohmann::json typo = nlohmann::json::parse(R"({"addded": 9})");
  try {
    TestSettings t;
    JsonNode(typo, "test.json", "").read_fields(t);
    ADD_FAILURE() << "a key outside the table was accepted";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("addded"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("added"), std::string::npos) << "the message lists the table's keys";
  }
}

// A value just outside field f's range, or a name no tag has.
template <class T>
T outside(double lo, double hi) {
  if constexpr (std::is_same_v<T, float>)
    return float(hi) * 2.0f + 1.0f;
  else if constexpr (std::is_same_v<T, Vec3>)
    return Vec3{float(hi) * 2.0f + 1.0f, 0.0f, 0.0f};
  else if constexpr (std::is_enum_v<T>)
    return T(tag_count<T>());
  else
    return T(hi + 1);
  (void)lo;
}

// Every field of S's table (reached in a scene by `of`, at JSON path `at`)
// is written under its key and read back equal, and a value outside its
// range is refused with the field's path in the message.
template <class S, class Of>
void check_table(const Scene& base, Of of, const std::string& at) {
  for_each_field<S>([&](const auto& f) {
    Scene probe = base;
    using T = std::remove_cv_t<std::remove_reference_t<decltype(of(probe).*f.member)>>;
    SCOPED_TRACE(at + "/" + f.key);
    const std::string text = scene_to_json(base);
    EXPECT_NE(text.find("\"" + std::string(f.key) + "\""), std::string::npos);
    Scene back = parse_scene(text, "round_trip.json", ".");
    EXPECT_TRUE(same_field_value(of(back).*f.member, of(probe).*f.member));
    // Outside its range (booleans and strings have none): refused, naming the field.
    if constexpr (!std::is_same_v<T, bool> && !std::is_same_v<T, std::string>) {
      Scene bad = base;
      of(bad).*f.member = outside<T>(f.lo, f.hi);
      try {
        validate_scene(bad);
        ADD_FAILURE() << "out of range accepted";
      } catch (const Error& e) {
        EXPECT_NE(std::string(e.what()).find(at + "/" + std::string(f.key)), std::string::npos) << e.what();
      }
    }
  });
}

TEST(Fields, EveryFieldOfEveryTableIsWrittenReadAndRangeChecked) {
  Scene base = cdsm_test::empty_scene("fields");
  base.lights.push_back(cdsm_test::spot_light({0, 5, 0}, {0, -1, 0}, 30, 25));
  base.lights[0].name = "lamp";
  check_table<ShadowSettings>(
      base, [](Scene& s) -> ShadowSettings& { return s.shadows; }, "/shadows");
  check_table<Camera>(
      base, [](Scene& s) -> Camera& { return s.camera; }, "/camera");
  check_table<Light>(
      base, [](Scene& s) -> Light& { return s.lights[0]; }, "/lights/0");
  base.objects.push_back(cdsm_test::surface_object("ground", make_quad(4.0f, 4.0f)));
  check_table<SurfaceMaterial>(
      base, [](Scene& s) -> SurfaceMaterial& { return s.objects[0].surface; }, "/objects/0/material");
  base.objects[0].name = "ground";
  check_table<Object>(
      base, [](Scene& s) -> Object& { return s.objects[0]; }, "/objects/0");
  Volume smoke;
  smoke.name = "smoke";
  NoiseVolumeParams noise;
  noise.nx = noise.ny = noise.nz = 6;
  smoke.grid = make_noise_volume(noise);
  smoke.transfer = {TransferPoint{}};
  base.volumes.push_back(smoke);
  Object box = cdsm_test::surface_object("smoke box", make_box({6, 6, 6}));
  box.interior = InteriorKind::Volume;
  box.volume = 0;
  base.objects.push_back(box);
  check_table<Volume>(
      base, [](Scene& s) -> Volume& { return s.volumes[0]; }, "/volumes/0");
}

}  // namespace
}  // namespace cdsm

namespace cdsm {
namespace {

// Each baseline's parameter is checked against its row of kMethodParams
// (cdsm/tags.h): its ends and 0 (the default) accepted, just past them and
// a fraction of an integer parameter refused, naming the method and range.
TEST(Fields, MethodParametersAreCheckedAgainstTheirTable) {
  Scene s = cdsm_test::empty_scene("params");
  s.lights.push_back(cdsm_test::spot_light({0, 5, 0}, {0, -1, 0}, 30, 25));
  for (ShadowMethod m : {ShadowMethod::ShadowMap, ShadowMethod::OpacitySlices, ShadowMethod::FixedNodes}) {
    const MethodParam& mp = method_param(m);
    SCOPED_TRACE(tag_name(m));
    s.shadows.method = m;
    for (float ok : {0.0f, mp.hi, mp.integer ? mp.lo : 0.25f}) {
      s.shadows.method_param = ok;
      EXPECT_NO_THROW(validate_scene(s)) << ok;
    }
    for (float bad : {mp.hi + 1.0f, mp.integer ? mp.lo + 0.5f : -0.25f}) {
      s.shadows.method_param = bad;
      try {
        validate_scene(s);
        ADD_FAILURE() << bad << " accepted";
      } catch (const Error& e) {
        const std::string w = e.what();
        EXPECT_NE(w.find(std::string(tag_name(m)) + ": " + mp.what), std::string::npos) << w;
        EXPECT_NE(w.find("[" + format_number(mp.lo) + ", " + format_number(mp.hi) + "]"), std::string::npos) << w;
      }
    }
  }
}

}  // namespace
}  // namespace cdsm
