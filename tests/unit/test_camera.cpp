// Camera from an engine's own view and projection matrices
// (Camera::from_matrices) against the look-at form, for OpenGL's and the
// [0, 1] clip depth, reversed and infinite projections; and the matrices
// it refuses, by name.
#include <gtest/gtest.h>

#include <cmath>
#include <glm/gtc/matrix_transform.hpp>
#include <glm/gtc/type_ptr.hpp>
#include <string>

#include "cdsm/error.h"
#include "cdsm/scene.h"
#include "frame.h"

using namespace cdsm;

namespace {

Camera look_at(Vec3 eye, Vec3 target, Vec3 up, float fov, int w, int h, float n, float f) {
  Camera c;
  c.position = eye;
  c.target = target;
  c.up = up;
  c.fov_y_deg = fov;
  c.width = w;
  c.height = h;
  c.near = n;
  c.far = f;
  return c;
}

// The camera pass and the clustering see a camera only as its pinhole view.
void expect_same_view(const Camera& a, const Camera& b, const std::string& what) {
  const PinholeView x = camera_view(a), y = camera_view(b);
  const float tol = 2e-5f;
  EXPECT_NEAR(length(x.eye - y.eye), 0.0f, tol * (1.0f + length(x.eye))) << what;
  EXPECT_NEAR(length(x.forward - y.forward), 0.0f, tol) << what;
  EXPECT_NEAR(length(x.right - y.right), 0.0f, tol) << what;
  EXPECT_NEAR(length(x.up - y.up), 0.0f, tol) << what;
  EXPECT_NEAR(x.tan_half_y, y.tan_half_y, tol * x.tan_half_y) << what;
  EXPECT_NEAR(x.tan_half_x, y.tan_half_x, tol * x.tan_half_x) << what;
  EXPECT_EQ(x.width, y.width) << what;
  EXPECT_EQ(x.height, y.height) << what;
  EXPECT_NEAR(x.near, y.near, 1e-4f * x.near) << what;
  // A float matrix holds the far plane in 1 + P22 ~ 2 near / far: its
  // relative error grows with far / near (float epsilon times that ratio).
  EXPECT_NEAR(x.far, y.far, (1e-5f + 1.2e-7f * x.far / x.near) * x.far) << what;
}

// glm::lookAt and glm::perspective(RH_NO / RH_ZO), written out from their
// definitions (column-major there; row-major here: m[row][col]).
Mat4 engine_look_at(Vec3 eye, Vec3 center, Vec3 up) {
  const Vec3 f = normalize(center - eye), s = normalize(cross(f, up)), u = cross(s, f);
  Mat4 m;
  const Vec3 rows[3] = {s, u, f * -1.0f};
  for (int i = 0; i < 3; ++i) {
    m.m[i][0] = rows[i].x;
    m.m[i][1] = rows[i].y;
    m.m[i][2] = rows[i].z;
  }
  m.m[0][3] = -dot(s, eye);
  m.m[1][3] = -dot(u, eye);
  m.m[2][3] = dot(f, eye);
  return m;
}
Mat4 engine_perspective(float fovy_rad, float aspect, float n, float f, bool zero_to_one) {
  const float t = std::tan(fovy_rad / 2.0f);
  Mat4 m;
  m.m[0][0] = 1.0f / (aspect * t);
  m.m[1][1] = 1.0f / t;
  m.m[2][2] = zero_to_one ? f / (n - f) : -(f + n) / (f - n);
  m.m[2][3] = zero_to_one ? -(f * n) / (f - n) : -(2.0f * f * n) / (f - n);
  m.m[3][2] = -1.0f;
  m.m[3][3] = 0.0f;
  return m;
}

std::string error_of(const Mat4& view, const Mat4& proj, int w, int h, ClipDepth d = ClipDepth::MinusOneToOne) {
  try {
    Camera::from_matrices(view, proj, w, h, d);
  } catch (const Error& e) {
    return e.what();
  }
  return "no error";
}

}  // namespace

// A look-at camera's own matrices give it back, in both clip depths.
TEST(CameraMatrices, RoundTripOfTheLookAtForm) {
  const Camera cams[] = {
      Camera{},
      look_at({3, 4, -2}, {0, 0.5f, 0}, {0, 1, 0}, 60.0f, 640, 360, 0.1f, 50.0f),
      look_at({0, 10, 0}, {0, 0, 0}, {0, 1, 0}, 30.0f, 256, 256, 0.5f, 1000.0f),  // up along the view
      look_at({-7, 1, 3}, {2, -1, 1}, {0.3f, 1, 0.1f}, 100.0f, 300, 600, 0.01f, 20.0f),
  };
  for (const Camera& c : cams)
    for (ClipDepth d : {ClipDepth::MinusOneToOne, ClipDepth::ZeroToOne}) {
      const Camera back = Camera::from_matrices(c.view_matrix(), c.projection_matrix(d), c.width, c.height, d);
      expect_same_view(c, back,
                       "fov " + std::to_string(c.fov_y_deg) + (d == ClipDepth::ZeroToOne ? " [0,1]" : " [-1,1]"));
      EXPECT_NEAR(back.fov_y_deg, c.fov_y_deg, 1e-3f);
    }
}

// An engine's matrices (glm's formulas): normal, [0, 1], reversed-Z with an
// infinite far plane.
TEST(CameraMatrices, EngineMatricesOfEveryDepthConvention) {
  const Vec3 eye{2, 3, 5}, center{0, 0.5f, 0}, up{0, 1, 0};
  const Camera want = look_at(eye, center, up, 50.0f, 800, 450, 0.1f, 300.0f);
  const float fovy = 50.0f * 3.14159265f / 180.0f, aspect = 800.0f / 450.0f;
  const Mat4 view = engine_look_at(eye, center, up);

  expect_same_view(want, Camera::from_matrices(view, engine_perspective(fovy, aspect, 0.1f, 300.0f, false), 800, 450),
                   "RH_NO");
  expect_same_view(
      want,
      Camera::from_matrices(view, engine_perspective(fovy, aspect, 0.1f, 300.0f, true), 800, 450, ClipDepth::ZeroToOne),
      "RH_ZO");

  // Reversed depth, [0, 1]: near -> 1, far -> 0.
  Mat4 rev = engine_perspective(fovy, aspect, 0.1f, 300.0f, true);
  rev.m[2][2] = 0.1f / (300.0f - 0.1f);
  rev.m[2][3] = 0.1f * 300.0f / (300.0f - 0.1f);
  expect_same_view(want, Camera::from_matrices(view, rev, 800, 450, ClipDepth::ZeroToOne), "reversed");

  // Reversed and infinite: z_clip = near, far at kMaxFar.
  Mat4 inf = rev;
  inf.m[2][2] = 0.0f;
  inf.m[2][3] = 0.1f;
  const Camera c = Camera::from_matrices(view, inf, 800, 450, ClipDepth::ZeroToOne);
  EXPECT_NEAR(c.near, 0.1f, 1e-6f);
  EXPECT_EQ(c.far, Camera::kMaxFar);
  // OpenGL's infinite projection: P22 = -1, P23 = -2 near.
  Mat4 gl_inf = engine_perspective(fovy, aspect, 0.1f, 300.0f, false);
  gl_inf.m[2][2] = -1.0f;
  gl_inf.m[2][3] = -0.2f;
  const Camera g = Camera::from_matrices(view, gl_inf, 800, 450);
  EXPECT_NEAR(g.near, 0.1f, 1e-6f);
  EXPECT_EQ(g.far, Camera::kMaxFar);
}

// glm's own matrices, handed over as glm holds them (column-major,
// glm::value_ptr), in both clip depths; a null pointer is refused by name.
TEST(CameraMatrices, GlmMatricesAsGiven) {
  const Camera want = look_at({2, 3, 5}, {0, 0.5f, 0}, {0, 1, 0}, 50.0f, 800, 450, 0.1f, 300.0f);
  const glm::mat4 view = glm::lookAt(glm::vec3(2, 3, 5), glm::vec3(0, 0.5f, 0), glm::vec3(0, 1, 0));
  const float fovy = glm::radians(50.0f), aspect = 800.0f / 450.0f;
  const glm::mat4 no = glm::perspectiveRH_NO(fovy, aspect, 0.1f, 300.0f);
  const glm::mat4 zo = glm::perspectiveRH_ZO(fovy, aspect, 0.1f, 300.0f);
  expect_same_view(want, Camera::from_matrices(glm::value_ptr(view), glm::value_ptr(no), 800, 450), "glm RH_NO");
  expect_same_view(want,
                   Camera::from_matrices(glm::value_ptr(view), glm::value_ptr(zo), 800, 450, ClipDepth::ZeroToOne),
                   "glm RH_ZO");
  // The column-major arrays are the transposes of the row-major Mat4s.
  const Camera rows = Camera::from_matrices(engine_look_at({2, 3, 5}, {0, 0.5f, 0}, {0, 1, 0}),
                                            engine_perspective(fovy, aspect, 0.1f, 300.0f, false), 800, 450);
  expect_same_view(rows, Camera::from_matrices(glm::value_ptr(view), glm::value_ptr(no), 800, 450), "Mat4 vs glm");
  try {
    Camera::from_matrices(glm::value_ptr(view), nullptr, 800, 450);
    ADD_FAILURE() << "a null projection was taken";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("projection is a null pointer"), std::string::npos) << e.what();
  }
}

// What does not describe this library's camera is refused, naming it.
TEST(CameraMatrices, RefusesWhatIsNotARigidViewAndASymmetricPerspective) {
  const Camera c = look_at({2, 3, 5}, {0, 0.5f, 0}, {0, 1, 0}, 50.0f, 800, 450, 0.1f, 300.0f);
  const Mat4 v = c.view_matrix(), p = c.projection_matrix();
  auto has = [](const std::string& e, const std::string& part) {
    EXPECT_NE(e.find(part), std::string::npos) << e;
    EXPECT_NE(e.find("Camera::from_matrices"), std::string::npos) << e;
  };
  Mat4 scaled = v;
  for (int j = 0; j < 4; ++j) scaled.m[0][j] *= 2.0f;
  has(error_of(scaled, p, 800, 450), "not a rigid motion");
  Mat4 mirrored = v;
  for (int j = 0; j < 4; ++j) mirrored.m[0][j] *= -1.0f;
  has(error_of(mirrored, p, 800, 450), "mirrors");
  Mat4 ortho = p;
  ortho.m[3][2] = 0.0f;
  ortho.m[3][3] = 1.0f;
  has(error_of(v, ortho, 800, 450), "orthographic");
  Mat4 skew = p;
  skew.m[0][2] = 0.2f;
  has(error_of(v, skew, 800, 450), "off-centre");
  has(error_of(v, p, 800, 800), "aspect ratio");
  Mat4 nan = p;
  nan.m[1][1] = std::nanf("");
  has(error_of(v, nan, 800, 450), "projection[1][1]");
  has(error_of(v, p, 0, 450), "0x450 pixels");
  Mat4 no_depth = p;
  no_depth.m[2][3] = 0.0f;
  has(error_of(v, no_depth, 800, 450), "no depth");
}
