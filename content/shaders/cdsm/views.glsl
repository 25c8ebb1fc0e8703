// cdsm.glsl, part 2 of 6 (content/shaders/cdsm/, joined by cmake/CdsmGlsl.cmake): math and views.

// ---- the math of cdsm/math.h, in its order of operations -------------------
// (GLSL's dot/length/normalize/mix may associate differently; these match
// the C++ to the last bit where the compiler does not contract.)

float cdsm_dot(vec3 a, vec3 b) { return a.x * b.x + a.y * b.y + a.z * b.z; }
float cdsm_length(vec3 a) { return sqrt(cdsm_dot(a, a)); }
vec3 cdsm_normalize(vec3 a) {
  float l = cdsm_length(a);
  return l > 0.0 ? a * (1.0 / l) : a;
}
float cdsm_lerp(float a, float b, float t) { return a + (b - a) * t; }
vec3 cdsm_over(vec3 alpha, vec3 a) { return alpha + a * (vec3(1.0) - alpha); }

// ---- views (shadows/hd/view.h) ----------------------------------------------

struct CdsmProjection {
  float u, v;    // texels
  float depth;   // radial distance from the eye; orthographic: from the window's plane
  float axial;   // along the view axis
};

CdsmProjection cdsm_project(CdsmView view, vec3 p) {
  vec3 d = p - view.eye;
  float za = cdsm_dot(d, view.forward);
  bool ortho = view.projection == CDSM_PROJECTION_ORTHOGRAPHIC;
  float inv = ortho ? 1.0 : za > 0.0 ? 1.0 / za : 0.0;
  float sx = cdsm_dot(d, view.right) * inv - view.center.x;
  float sy = cdsm_dot(d, view.up) * inv - view.center.y;
  CdsmProjection r;
  r.u = (sx / view.tan_half_x + 1.0) * 0.5 * float(view.width);
  r.v = (1.0 - sy / view.tan_half_y) * 0.5 * float(view.height);
  r.depth = ortho ? za : cdsm_length(d);
  r.axial = za;
  return r;
}

vec2 cdsm_window_at(CdsmView view, float u, float v) {
  return vec2(view.center.x + (2.0 * u / float(view.width) - 1.0) * view.tan_half_x,
              view.center.y + (1.0 - 2.0 * v / float(view.height)) * view.tan_half_y);
}

