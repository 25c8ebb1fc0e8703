#include "cdsm/image.h"

#include <stb/stb_image_write.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include "cdsm/error.h"

namespace cdsm {
namespace {

float to_srgb(float c) {
  c = std::clamp(std::isfinite(c) ? c : 0.0f, 0.0f, 1.0f);
  return c <= 0.0031308f ? 12.92f * c : 1.055f * std::pow(c, 1.0f / 2.4f) - 0.055f;
}

}  // namespace

void write_png(const Image& image, const std::string& path) {
  if (image.width <= 0 || image.height <= 0 || image.rgb.size() != size_t(image.width) * image.height * 3)
    throw Error(path, "image is empty or has inconsistent size");
  std::vector<unsigned char> px(image.rgb.size());
  for (size_t i = 0; i < px.size(); ++i) px[i] = (unsigned char)std::lround(to_srgb(image.rgb[i]) * 255.0f);
  if (!stbi_write_png(path.c_str(), image.width, image.height, 3, px.data(), image.width * 3))
    throw Error(path, "cannot write PNG (directory missing or not writable?)");
}

ImageError compare_images(const Image& a, const Image& b) {
  if (a.width != b.width || a.height != b.height || a.rgb.size() != b.rgb.size())
    throw Error("compare_images", "images differ in size");
  double se = 0.0;
  for (size_t i = 0; i < a.rgb.size(); ++i) {
    double d = double(to_srgb(a.rgb[i])) - double(to_srgb(b.rgb[i]));
    se += d * d;
  }
  ImageError e;
  e.rmse = a.rgb.empty() ? 0.0 : std::sqrt(se / double(a.rgb.size()));
  e.psnr = e.rmse > 0.0 ? 20.0 * std::log10(1.0 / e.rmse) : std::numeric_limits<double>::infinity();
  return e;
}

Image error_heatmap(const Image& a, const Image& b, float full_scale) {
  if (a.width != b.width || a.height != b.height) throw Error("error_heatmap", "images differ in size");
  Image h;
  h.width = a.width;
  h.height = a.height;
  h.rgb.resize(a.rgb.size());
  for (size_t p = 0; p < size_t(a.width) * a.height; ++p) {
    float e = 0.0f;
    for (int c = 0; c < 3; ++c) e = std::max(e, std::fabs(to_srgb(a.rgb[3 * p + c]) - to_srgb(b.rgb[3 * p + c])));
    float t = std::clamp(e / full_scale, 0.0f, 1.0f);
    // black -> blue -> red -> yellow
    float r = std::clamp(2.0f * t - 0.5f, 0.0f, 1.0f), g = std::clamp(2.0f * t - 1.2f, 0.0f, 1.0f) * 1.25f,
          bl = t < 0.5f ? 2.0f * t : std::max(0.0f, 2.0f - 2.5f * t);
    // Stored linear: write_png encodes to sRGB, so undo that for a faithful ramp.
    auto lin = [](float c) { return c <= 0.04045f ? c / 12.92f : std::pow((c + 0.055f) / 1.055f, 2.4f); };
    h.rgb[3 * p] = lin(std::min(r, 1.0f));
    h.rgb[3 * p + 1] = lin(std::min(g, 1.0f));
    h.rgb[3 * p + 2] = lin(std::min(bl, 1.0f));
  }
  return h;
}

}  // namespace cdsm
