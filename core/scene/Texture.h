#pragma once
// Decoded textures and their sampling (glTF 2.0 spec 3.8 "Texture Data": samplers, wrap modes,
// filters; 3.9.2 "baseColorTexture ... MUST be in sRGB"). Images are decoded by OpenImageIO
// (any format it reads; glTF files use PNG and JPEG) into linear float RGBA.
#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include "core/math/Vec3.h"

namespace ps {

/// A decoded image: linear float RGBA, 4 floats per texel, row-major, row 0 at the top (glTF's
/// UV (0,0) is the top-left corner of the image, spec 3.8.1).
struct Image {
  std::string name;  ///< for messages: the glTF path (`images[2]`) and the uri if any
  int width = 0;
  int height = 0;
  std::vector<float> rgba;  ///< width * height * 4; colour decoded from sRGB, alpha linear

  const float* texel(int x, int y) const {
    return &rgba[(static_cast<size_t>(y) * static_cast<size_t>(width) + static_cast<size_t>(x)) *
                 4];
  }
};

enum class TextureWrap { Repeat, ClampToEdge, MirroredRepeat };

/// A material's use of an image: which image, and the sampler's wrap modes and filter.
struct TextureRef {
  int image = -1;  ///< index into Scene::images; -1 = no texture
  TextureWrap wrapS = TextureWrap::Repeat;
  TextureWrap wrapT = TextureWrap::Repeat;
  bool nearest = false;  ///< magFilter NEAREST; otherwise bilinear

  bool valid() const { return image >= 0; }
};

/// The sRGB transfer function, inverted (IEC 61966-2-1): encoded value in [0, 1] to linear.
double srgbToLinear(double encoded);

/// Maps one texture coordinate to [0, 1) per the wrap mode (glTF 3.8.4, after OpenGL 4.6
/// sec. 8.14.2): Repeat takes the fractional part; ClampToEdge clamps; MirroredRepeat mirrors
/// every other repetition.
double wrapCoordinate(double s, TextureWrap wrap);

/// The RGBA of `image` at texture coordinates (s, t): nearest texel, or bilinear between the
/// four nearest texel centres (texel centres at (i + 0.5) / width), the wrap applied to each
/// texel index. Precondition: the image is not empty.
void sampleImage(const Image& image, const TextureRef& ref, double s, double t, float out[4]);

/// Decodes an encoded image (PNG, JPEG, or anything OpenImageIO reads) held in memory.
/// `hint` is a file name or mime type used to choose the decoder first. Colour channels are
/// decoded from sRGB to linear (`srgb`), alpha stays linear; grey images are replicated to
/// RGB, images without alpha get alpha 1. Returns nothing, with the reason in `why`, when the
/// bytes cannot be decoded.
std::optional<Image> decodeImage(const unsigned char* bytes, size_t size, const std::string& hint,
                                 bool srgb, std::string& why);

/// Reads a linear floating-point image file (.hdr, .exr, anything OpenImageIO reads) as RGBA
/// without colour conversion. Returns nothing, with the reason in `why`, when it cannot.
std::optional<Image> readLinearImage(const std::string& path, std::string& why);

}  // namespace ps
