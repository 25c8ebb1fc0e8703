// cdsm bench: the exact reference of a view, rendered once and cached on
// disk under a hash of everything it depends on.
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <exception>
#include <filesystem>
#include <fstream>
#include <thread>

#include "bench.h"
#include "cdsm/fields.h"

namespace cdsm::cli::bench {
namespace {

// Bump when the reference renderer's output changes, so old caches miss.
// v3: objects, volumes and the camera by their field tables too
constexpr const char* kReferenceCacheSalt = "cdsm-reference-v3";
// Every field that changes what is drawn (names and budgets do not).
constexpr uint32_t kEveryEffect = kAffectsLookup | kAffectsPlan | kAffectsClusters | kAffectsMaps;

// The cache key: cdsm::Fnv1a with the values a scene holds.
struct Hasher : Fnv1a {
  void f(float v) { bytes(&v, sizeof v); }
  void i(int64_t v) { bytes(&v, sizeof v); }
  void v3(Vec3 v) {
    f(v.x);
    f(v.y);
    f(v.z);
  }
  void m4(const Mat4& m) { bytes(&m.m[0][0], sizeof m.m); }
  void s(const std::string& v) {
    i(int64_t(v.size()));
    bytes(v.data(), v.size());
  }
  template <class T>
  void pod(const T& v) {
    bytes(&v, sizeof v);
  }
  template <class T>
  void vec(const std::vector<T>& v) {
    i(int64_t(v.size()));
    bytes(v.data(), v.size() * sizeof(T));
  }
};

struct CacheHeader {
  char magic[8];  // "CDSMREF1"
  int32_t width, height;
  double ms;
};

bool read_cache(const std::string& path, Reference& ref, int w, int h) {
  std::ifstream in(path, std::ios::binary);
  if (!in) return false;
  CacheHeader hd{};
  in.read(reinterpret_cast<char*>(&hd), sizeof hd);
  if (!in || std::memcmp(hd.magic, "CDSMREF1", 8) != 0 || hd.width != w || hd.height != h) return false;
  ref.image.width = w;
  ref.image.height = h;
  ref.image.rgb.resize(size_t(w) * h * 3);
  in.read(reinterpret_cast<char*>(ref.image.rgb.data()), std::streamsize(ref.image.rgb.size() * sizeof(float)));
  if (!in) return false;
  ref.ms = hd.ms;
  return true;
}

void write_cache(const std::string& path, const Reference& ref, const Scene& scene) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(fs::path(path).parent_path(), ec);
  std::string tmp = path + ".tmp" + std::to_string(::getpid());
  {
    std::ofstream out(tmp, std::ios::binary);
    if (!out) {
      std::fprintf(stderr, "cdsm bench: warning: cannot write the reference cache %s\n", path.c_str());
      return;
    }
    CacheHeader hd{};
    std::memcpy(hd.magic, "CDSMREF1", 8);
    hd.width = ref.image.width;
    hd.height = ref.image.height;
    hd.ms = ref.ms;
    out.write(reinterpret_cast<const char*>(&hd), sizeof hd);
    out.write(reinterpret_cast<const char*>(ref.image.rgb.data()),
              std::streamsize(ref.image.rgb.size() * sizeof(float)));
  }
  fs::rename(tmp, path, ec);  // atomic: a concurrent reader sees all or nothing
  std::ofstream note(path.substr(0, path.size() - 4) + ".txt");
  note << "reference of " << scene.source << ", " << ref.image.width << "x" << ref.image.height << ", rendered in "
       << ref.ms << " ms\n";
}

// A progress bar for a computation that cannot report progress: its time is
// estimated from a small render of the same view (pixel cost scales with area).
class ProgressBar {
 public:
  ProgressBar(std::string what, double estimate_ms) : what_(std::move(what)), estimate_ms_(estimate_ms) {
    tty_ = ::isatty(STDERR_FILENO) == 1;
    if (!tty_) std::fprintf(stderr, "%s: rendering (estimated %.1f s) ...\n", what_.c_str(), estimate_ms_ / 1000.0);
  }
  void update(double elapsed_ms) {
    if (!tty_) return;
    double frac = estimate_ms_ > 0 ? std::min(0.99, elapsed_ms / estimate_ms_) : 0.0;
    draw(frac, elapsed_ms, false);
  }
  void done(double elapsed_ms) {
    if (tty_)
      draw(1.0, elapsed_ms, true);
    else
      std::fprintf(stderr, "%s: done in %.1f s\n", what_.c_str(), elapsed_ms / 1000.0);
  }

 private:
  void draw(double frac, double elapsed_ms, bool final) {
    const int width = 30;
    int fill = int(frac * width + 0.5);
    std::string bar(size_t(fill), '#');
    bar.append(size_t(width - fill), '.');
    std::fprintf(stderr, "\r%s [%s] %3d%%  %.1f s%s", what_.c_str(), bar.c_str(), int(frac * 100.0 + 0.5),
                 elapsed_ms / 1000.0,
                 final ? "          \n" : (" of ~" + fmt_s(std::max(estimate_ms_, elapsed_ms)) + " (est.)").c_str());
    std::fflush(stderr);
  }
  static std::string fmt_s(double ms) {
    char b[32];
    std::snprintf(b, sizeof b, "%.1f s", ms / 1000.0);
    return b;
  }
  std::string what_;
  double estimate_ms_;
  bool tty_ = false;
};

double ms_between(std::chrono::steady_clock::time_point a, std::chrono::steady_clock::time_point b) {
  return std::chrono::duration<double, std::milli>(b - a).count();
}

// Renders the reference on a worker thread while the bar advances.
Reference render_with_progress(const Scene& scene, const RenderOptions& opt) {
  RenderOptions o = opt;
  o.backend = Backend::Reference;
  o.fragments = FragmentSource::Cpu;  // the reference needs no fragment lists: no GL context on the worker
  // Estimate: the same view at 1/8 x 1/8 of the pixels.
  Scene small = scene;
  small.camera.width = std::max(8, scene.camera.width / 8);
  small.camera.height = std::max(8, scene.camera.height / 8);
  double estimate = 0.0;
  {
    Renderer r;
    FrameStats st;
    r.render_reference(small, o, &st);
    double per_pixel = st.times.reference_ms / (double(small.camera.width) * small.camera.height);
    estimate = st.times.compile_ms + per_pixel * double(scene.camera.width) * scene.camera.height;
  }
  char what[256];
  std::snprintf(what, sizeof what, "reference %s %dx%d", std::filesystem::path(scene.source).filename().c_str(),
                scene.camera.width, scene.camera.height);
  ProgressBar bar(what, estimate);
  Reference ref;
  std::exception_ptr failure;
  std::atomic<bool> finished{false};
  auto t0 = std::chrono::steady_clock::now();
  std::thread worker([&] {
    try {
      Renderer r;
      FrameStats st;
      ref.image = r.render_reference(scene, o, &st);
      ref.ms = st.times.reference_ms;  // the renderer's own time, scene compilation excluded
    } catch (...) {
      failure = std::current_exception();
    }
    finished = true;
  });
  while (!finished) {
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
    bar.update(ms_between(t0, std::chrono::steady_clock::now()));
  }
  worker.join();
  if (failure) std::rethrow_exception(failure);
  bar.done(ms_between(t0, std::chrono::steady_clock::now()));
  return ref;
}

}  // namespace

std::string reference_key(const Scene& s, float step_voxels) {
  Hasher h;
  h.s(kReferenceCacheSalt);
  h.f(step_voxels);
  h.i(int64_t(s.objects.size()));
  for (const Object& o : s.objects) {
    if (o.mesh) {
      h.vec(o.mesh->positions);
      h.vec(o.mesh->indices);
      h.vec(o.mesh->normals);
    }
    h.m4(o.transform);
    hash_fields(h, o, kEveryEffect);          // the object's table (casts_shadows)
    hash_fields(h, o.surface, kEveryEffect);  // every field of the material's table
    h.i(int64_t(o.interior));
    h.v3(o.sigma);
    h.i(o.volume);
  }
  h.i(int64_t(s.volumes.size()));
  for (const Volume& v : s.volumes) {
    if (v.grid) {
      h.i(v.grid->nx);
      h.i(v.grid->ny);
      h.i(v.grid->nz);
      h.vec(v.grid->values);
      h.f(v.grid->background);
    }
    h.m4(v.index_to_object);
    h.vec(v.transfer);
    hash_fields(h, v, kEveryEffect);  // shading, step, gradient scale
  }
  h.i(int64_t(s.lights.size()));
  for (const Light& l : s.lights) hash_fields(h, l, kEveryEffect);  // its size too: an area light's reference
  hash_fields(h, s.camera, kEveryEffect);                           // every field of the camera's table
  h.v3(s.shadows.ambient_light);
  h.v3(s.background);
  char hex[17];
  std::snprintf(hex, sizeof hex, "%016llx", (unsigned long long)h.h);
  return hex;
}

std::string default_cache_dir() {
  if (const char* d = std::getenv("CDSM_CACHE_DIR"); d && *d) return d;
  if (const char* d = std::getenv("XDG_CACHE_HOME"); d && *d) return std::string(d) + "/cdsm";
  if (const char* d = std::getenv("HOME"); d && *d) return std::string(d) + "/.cache/cdsm";
  return ".cdsm-cache";
}

Reference reference_for(const Scene& scene, const RenderOptions& opt, const std::string& cache_dir, bool refresh) {
  std::string key = reference_key(scene, opt.reference_step_voxels);
  std::string path = cache_dir.empty() ? "" : cache_dir + "/reference-" + key + ".bin";
  Reference ref;
  if (!path.empty() && !refresh && read_cache(path, ref, scene.camera.width, scene.camera.height)) {
    ref.cached = true;
    ref.key = key;
    ref.path = path;
    std::fprintf(stderr, "reference %s %dx%d: cached (%s, rendered in %.1f s)\n",
                 std::filesystem::path(scene.source).filename().c_str(), scene.camera.width, scene.camera.height,
                 path.c_str(), ref.ms / 1000.0);
    return ref;
  }
  ref = render_with_progress(scene, opt);
  ref.key = key;
  ref.path = path;
  if (!path.empty()) write_cache(path, ref, scene);
  return ref;
}

}  // namespace cdsm::cli::bench
