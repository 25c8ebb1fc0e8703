// Linear-RGB float images and PNG output.
#pragma once

#include <string>
#include <vector>

namespace cdsm {

struct Image {
  int width = 0, height = 0;
  std::vector<float> rgb;  // 3 floats per pixel, linear, row 0 at the top
};

// Writes an 8-bit sRGB PNG. Throws cdsm::Error naming the path on failure.
void write_png(const Image& image, const std::string& path);

// RMSE and PSNR (peak 1) of the sRGB-encoded images, the way a viewer sees them.
struct ImageError {
  double rmse = 0.0;
  double psnr = 0.0;  // dB; infinite when identical
};
ImageError compare_images(const Image& a, const Image& b);

// A heat map of |a - b| (per-pixel max over channels, in sRGB), scaled so
// `full_scale` maps to the hottest colour.
Image error_heatmap(const Image& a, const Image& b, float full_scale = 0.1f);

}  // namespace cdsm
