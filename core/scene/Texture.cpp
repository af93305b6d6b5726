// Texture decoding (OpenImageIO) and sampling (glTF 2.0 spec 3.8.4 samplers: wrap modes and
// magnification filters, as OpenGL 4.6 sec. 8.14.2 defines them).
#include "core/scene/Texture.h"

#include <OpenImageIO/filesystem.h>
#include <OpenImageIO/imageio.h>

#include <algorithm>
#include <cmath>
#include <cstring>

namespace ps {

namespace {

/// Images larger than this many texels are refused (a corrupt header must not make us allocate
/// gigabytes): 2^26 texels is an 8192 x 8192 texture.
constexpr size_t kMaxTexels = size_t{1} << 26;

/// A file name whose extension picks OpenImageIO's decoder, from the magic bytes (glTF's
/// mimeType may be absent or wrong); OpenImageIO tries its other decoders when this one fails.
std::string decoderName(const unsigned char* bytes, size_t size, const std::string& hint) {
  auto starts = [&](const char* magic, size_t n) {
    return size >= n && std::memcmp(bytes, magic, n) == 0;
  };
  if (starts("\x89PNG", 4)) return "image.png";
  if (starts("\xFF\xD8\xFF", 3)) return "image.jpg";
  if (starts("#?RADIANCE", 10) || starts("#?RGBE", 6)) return "image.hdr";
  if (starts("\x76\x2F\x31\x01", 4)) return "image.exr";
  if (starts("BM", 2)) return "image.bmp";
  if (hint.find("png") != std::string::npos) return "image.png";
  if (hint.find("jpeg") != std::string::npos || hint.find("jpg") != std::string::npos)
    return "image.jpg";
  return hint.empty() ? "image.png" : hint;
}

/// Reads the whole first subimage as float RGBA from an open input.
std::optional<Image> readRgba(OIIO::ImageInput& in, bool srgb, std::string& why) {
  const OIIO::ImageSpec& spec = in.spec();
  if (spec.width <= 0 || spec.height <= 0 || spec.nchannels <= 0 || spec.depth != 1) {
    why = "has no 2D pixels (" + std::to_string(spec.width) + " x " + std::to_string(spec.height) +
          " x " + std::to_string(spec.depth) + ", " + std::to_string(spec.nchannels) + " channels)";
    return std::nullopt;
  }
  const size_t texels = static_cast<size_t>(spec.width) * static_cast<size_t>(spec.height);
  if (texels > kMaxTexels) {
    why = "is too large (" + std::to_string(spec.width) + " x " + std::to_string(spec.height) +
          " texels, at most " + std::to_string(kMaxTexels) + ")";
    return std::nullopt;
  }
  const int channels = spec.nchannels;
  std::vector<float> raw(texels * static_cast<size_t>(channels));
  if (!in.read_image(0, 0, 0, channels, OIIO::TypeDesc::FLOAT, raw.data())) {
    why = "cannot be decoded: " + in.geterror();
    return std::nullopt;
  }
  Image img;
  img.width = spec.width;
  img.height = spec.height;
  img.rgba.resize(texels * 4);
  const int alphaChannel = spec.alpha_channel >= 0 ? spec.alpha_channel : (channels == 4 ? 3 : -1);
  for (size_t i = 0; i < texels; ++i) {
    const float* src = &raw[i * static_cast<size_t>(channels)];
    float* dst = &img.rgba[i * 4];
    const int colour = channels >= 3 ? 3 : 1;  // grey (+ alpha) replicates channel 0
    for (int c = 0; c < 3; ++c) {
      const float v = src[colour == 3 ? c : 0];
      dst[c] = srgb ? static_cast<float>(srgbToLinear(v)) : v;
    }
    dst[3] = alphaChannel >= 0 && alphaChannel < channels ? src[alphaChannel]
             : channels == 2                              ? src[1]
                                                          : 1.0f;
  }
  return img;
}

}  // namespace

double srgbToLinear(double encoded) {
  // IEC 61966-2-1: linear segment below 0.04045, power 2.4 above.
  const double c = std::clamp(encoded, 0.0, 1.0);
  return c <= 0.04045 ? c / 12.92 : std::pow((c + 0.055) / 1.055, 2.4);
}

double wrapCoordinate(double s, TextureWrap wrap) {
  if (!std::isfinite(s)) return 0.0;
  switch (wrap) {
    case TextureWrap::Repeat:
      return s - std::floor(s);
    case TextureWrap::ClampToEdge:
      return std::clamp(s, 0.0, std::nextafter(1.0, 0.0));
    case TextureWrap::MirroredRepeat: {
      // mirror(s) = s - floor(s) on even repetitions, 1 - (s - floor(s)) on odd ones.
      const double f = std::floor(s);
      const double frac = s - f;
      const bool odd = std::fmod(std::abs(f), 2.0) == 1.0;
      return odd ? std::clamp(1.0 - frac, 0.0, std::nextafter(1.0, 0.0)) : frac;
    }
  }
  return 0.0;
}

namespace {

/// Texel index i (possibly outside [0, n)) wrapped per the mode: the discrete form of
/// wrapCoordinate used by bilinear filtering (OpenGL 4.6 sec. 8.14.2, wrap applied per texel).
int wrapIndex(long long i, int n, TextureWrap wrap) {
  switch (wrap) {
    case TextureWrap::Repeat: {
      const long long m = i % n;
      return static_cast<int>(m < 0 ? m + n : m);
    }
    case TextureWrap::ClampToEdge:
      return static_cast<int>(std::clamp<long long>(i, 0, n - 1));
    case TextureWrap::MirroredRepeat: {
      const long long period = 2LL * n;
      long long m = i % period;
      if (m < 0) m += period;
      return static_cast<int>(m < n ? m : period - 1 - m);
    }
  }
  return 0;
}

}  // namespace

void sampleImage(const Image& image, const TextureRef& ref, double s, double t, float out[4]) {
  const int w = image.width, h = image.height;
  if (ref.nearest) {
    const double ws = wrapCoordinate(s, ref.wrapS), wt = wrapCoordinate(t, ref.wrapT);
    const int x = std::min(w - 1, static_cast<int>(ws * w));
    const int y = std::min(h - 1, static_cast<int>(wt * h));
    std::memcpy(out, image.texel(x, y), 4 * sizeof(float));
    return;
  }
  // Bilinear: texel centres at (i + 0.5) / w. Coordinates are first reduced to one period of
  // their wrap mode (so huge UVs do not overflow), then the four neighbours are wrapped one by
  // one.
  auto reduce = [](double c, TextureWrap wrap) {
    if (!std::isfinite(c)) return 0.0;
    switch (wrap) {
      case TextureWrap::Repeat:
        return c - std::floor(c);
      case TextureWrap::MirroredRepeat:
        return c - 2.0 * std::floor(c / 2.0);
      case TextureWrap::ClampToEdge:
        return std::clamp(c, -1.0, 2.0);
    }
    return 0.0;
  };
  const double cx = reduce(s, ref.wrapS) * w - 0.5;
  const double cy = reduce(t, ref.wrapT) * h - 0.5;
  const double fx = std::floor(cx), fy = std::floor(cy);
  const double ax = cx - fx, ay = cy - fy;
  const auto x0 = static_cast<long long>(fx);
  const auto y0 = static_cast<long long>(fy);
  const int xa = wrapIndex(x0, w, ref.wrapS), xb = wrapIndex(x0 + 1, w, ref.wrapS);
  const int ya = wrapIndex(y0, h, ref.wrapT), yb = wrapIndex(y0 + 1, h, ref.wrapT);
  const float* p00 = image.texel(xa, ya);
  const float* p10 = image.texel(xb, ya);
  const float* p01 = image.texel(xa, yb);
  const float* p11 = image.texel(xb, yb);
  for (int c = 0; c < 4; ++c)
    out[c] = static_cast<float>((1 - ay) * ((1 - ax) * p00[c] + ax * p10[c]) +
                                ay * ((1 - ax) * p01[c] + ax * p11[c]));
}

std::optional<Image> decodeImage(const unsigned char* bytes, size_t size, const std::string& hint,
                                 bool srgb, std::string& why) {
  if (!bytes || size == 0) {
    why = "is empty";
    return std::nullopt;
  }
  OIIO::Filesystem::IOMemReader mem(bytes, size);
  OIIO::Filesystem::IOProxy* proxy = &mem;
  OIIO::ImageSpec config;
  // With a configuration, OpenImageIO 2.4 takes the proxy from this attribute.
  config.attribute("oiio:ioproxy", OIIO::TypeDesc::PTR, &proxy);
  // Keep straight (unassociated) alpha: glTF colours are not premultiplied, and a cut-out
  // texel's colour must not be darkened by its alpha.
  config.attribute("oiio:UnassociatedAlpha", 1);
  auto in = OIIO::ImageInput::open(decoderName(bytes, size, hint), &config, &mem);
  if (!in) {
    why = "cannot be decoded: " + OIIO::geterror();
    return std::nullopt;
  }
  auto img = readRgba(*in, srgb, why);
  in->close();
  return img;
}

std::optional<Image> readLinearImage(const std::string& path, std::string& why) {
  auto in = OIIO::ImageInput::open(path);
  if (!in) {
    why = "cannot be read: " + OIIO::geterror();
    return std::nullopt;
  }
  auto img = readRgba(*in, /*srgb=*/false, why);
  in->close();
  if (img) img->name = path;
  return img;
}

}  // namespace ps
