// ps::loadScene: glTF 2.0 (.gltf with external or data-URI buffers, .glb) flattened to
// world-space triangle arrays. tinygltf parses the JSON and resolves the buffers; every
// accessor, buffer view and index is validated here before a byte is read, so no input can
// make us read out of bounds.
//
// Spec references are to the glTF 2.0 specification (Khronos, 2021):
//   3.5.3 node transforms (TRS / matrix, column-major), 3.6.2.4 accessor data alignment and
//   bounds, 3.7.2.1 primitive modes (strip / fan vertex order), 3.7.2.1 "flat normals when
//   NORMAL is absent", 3.7.4 "a negative determinant reverses the winding order".
// Extensions: KHR_lights_punctual (lights point along the node's local -Z),
// KHR_materials_emissive_strength, KHR_materials_pbrSpecularGlossiness (diffuseFactor and
// diffuseTexture as the albedo; specular and glossiness are not Lambertian and are ignored).
//
// Choices documented here:
//   * Missing normals: flat normals (the spec asks for them); every triangle of such a primitive
//     gets three vertices of its own with the world-space face normal. A zero-area triangle gets
//     +Y so that every normal is unit length.
//   * Albedo is baseColorFactor only (textures are ignored); emission is emissiveFactor times
//     emissiveStrength. Every glTF material becomes a ps::Material at the same index; a white
//     "default" material is appended when some primitive names none.
//   * POINTS and LINES primitives carry no surface and are skipped; a primitive without POSITION
//     is skipped (the spec says it is not rendered).
//   * Degenerate triangles (repeated indices, zero area) are kept, so triangle counts equal the
//     glTF index counts.
//   * Without a default scene ("scene" absent or out of range) every root node is flattened.
#include <tiny_gltf.h>

#include <array>
#include <cmath>
#include <cstring>
#include <fstream>
#include <limits>
#include <map>
#include <sstream>

#include "core/common/Error.h"
#include "core/scene/Scene.h"
#include "core/scene/SceneUnits.h"

namespace ps {
namespace {

/// Column-major 4x4 affine transform as in glTF: m[col * 4 + row].
struct Mat4 {
  std::array<double, 16> m{1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1};
  double at(int row, int col) const { return m[col * 4 + row]; }
  double& at(int row, int col) { return m[col * 4 + row]; }
};

Mat4 operator*(const Mat4& a, const Mat4& b) {
  Mat4 r;
  for (int row = 0; row < 4; ++row)
    for (int col = 0; col < 4; ++col) {
      double s = 0;
      for (int k = 0; k < 4; ++k) s += a.at(row, k) * b.at(k, col);
      r.at(row, col) = s;
    }
  return r;
}

Vec3 transformPoint(const Mat4& a, Vec3 p) {
  return {a.at(0, 0) * p.x + a.at(0, 1) * p.y + a.at(0, 2) * p.z + a.at(0, 3),
          a.at(1, 0) * p.x + a.at(1, 1) * p.y + a.at(1, 2) * p.z + a.at(1, 3),
          a.at(2, 0) * p.x + a.at(2, 1) * p.y + a.at(2, 2) * p.z + a.at(2, 3)};
}

Vec3 transformVector(const Mat4& a, Vec3 v) {
  return {a.at(0, 0) * v.x + a.at(0, 1) * v.y + a.at(0, 2) * v.z,
          a.at(1, 0) * v.x + a.at(1, 1) * v.y + a.at(1, 2) * v.z,
          a.at(2, 0) * v.x + a.at(2, 1) * v.y + a.at(2, 2) * v.z};
}

double determinant3(const Mat4& a) {
  return a.at(0, 0) * (a.at(1, 1) * a.at(2, 2) - a.at(1, 2) * a.at(2, 1)) -
         a.at(0, 1) * (a.at(1, 0) * a.at(2, 2) - a.at(1, 2) * a.at(2, 0)) +
         a.at(0, 2) * (a.at(1, 0) * a.at(2, 1) - a.at(1, 1) * a.at(2, 0));
}

/// The inverse transpose of the upper 3x3 (cofactor matrix / determinant), in a Mat4 with no
/// translation; normals transform by it. Precondition: det != 0.
Mat4 normalMatrix(const Mat4& a, double det) {
  Mat4 r;
  for (int row = 0; row < 3; ++row)
    for (int col = 0; col < 3; ++col) {
      const int r1 = (row + 1) % 3, r2 = (row + 2) % 3, c1 = (col + 1) % 3, c2 = (col + 2) % 3;
      r.at(row, col) = (a.at(r1, c1) * a.at(r2, c2) - a.at(r1, c2) * a.at(r2, c1)) / det;
    }
  return r;
}

/// glTF node local transform (spec 3.5.3): the matrix if given, else T * R * S.
Mat4 localTransform(const tinygltf::Node& node) {
  Mat4 r;
  if (node.matrix.size() == 16) {
    for (int i = 0; i < 16; ++i) r.m[i] = node.matrix[i];
    return r;
  }
  if (node.rotation.size() == 4) {
    double x = node.rotation[0], y = node.rotation[1], z = node.rotation[2], w = node.rotation[3];
    const double n = std::sqrt(x * x + y * y + z * z + w * w);
    if (n > 0) x /= n, y /= n, z /= n, w /= n;
    r.at(0, 0) = 1 - 2 * (y * y + z * z);
    r.at(0, 1) = 2 * (x * y - z * w);
    r.at(0, 2) = 2 * (x * z + y * w);
    r.at(1, 0) = 2 * (x * y + z * w);
    r.at(1, 1) = 1 - 2 * (x * x + z * z);
    r.at(1, 2) = 2 * (y * z - x * w);
    r.at(2, 0) = 2 * (x * z - y * w);
    r.at(2, 1) = 2 * (y * z + x * w);
    r.at(2, 2) = 1 - 2 * (x * x + y * y);
  }
  if (node.scale.size() == 3)
    for (int row = 0; row < 3; ++row)
      for (int col = 0; col < 3; ++col) r.at(row, col) *= node.scale[col];
  if (node.translation.size() == 3)
    for (int row = 0; row < 3; ++row) r.at(row, 3) = node.translation[row];
  return r;
}

/// tinygltf's error text as one printable line: newlines become spaces and any other control
/// or non-ASCII byte (parse errors quote raw bytes of the file) becomes '?'.
std::string oneLine(std::string s) {
  for (char& c : s) {
    const auto u = static_cast<unsigned char>(c);
    if (c == '\n' || c == '\r' || c == '\t')
      c = ' ';
    else if (u < 0x20 || u >= 0x7f)
      c = '?';
  }
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s;
}

std::string indexed(const char* array, size_t i) {
  return std::string(array) + "[" + std::to_string(i) + "]";
}

/// A validated, strided view of an accessor's elements.
struct AccessorView {
  const unsigned char* data = nullptr;
  size_t stride = 0;
  size_t count = 0;
  int componentType = 0;
  int components = 0;
};

/// Image loader that keeps the encoded bytes: only the images a material uses as a colour are
/// decoded (by OpenImageIO, in Flattener::sceneImage), and a bad image is a warning, not a
/// failed load (returning true keeps tinygltf going).
bool keepEncodedImage(tinygltf::Image* image, const int, std::string*, std::string*, int, int,
                      const unsigned char* bytes, int size, void*) {
  if (bytes && size > 0) image->image.assign(bytes, bytes + size);
  image->as_is = true;
  return true;
}

TextureWrap toWrap(int glWrap) {
  switch (glWrap) {
    case TINYGLTF_TEXTURE_WRAP_CLAMP_TO_EDGE:
      return TextureWrap::ClampToEdge;
    case TINYGLTF_TEXTURE_WRAP_MIRRORED_REPEAT:
      return TextureWrap::MirroredRepeat;
    default:
      return TextureWrap::Repeat;
  }
}

class Flattener {
 public:
  Flattener(const tinygltf::Model& model, std::string file, Scene& scene)
      : model_(model), file_(std::move(file)), scene_(scene) {}

  void run() {
    convertMaterials();
    std::vector<int> roots;
    if (model_.defaultScene >= 0 && size_t(model_.defaultScene) < model_.scenes.size()) {
      roots = model_.scenes[size_t(model_.defaultScene)].nodes;
    } else {
      std::vector<char> isChild(model_.nodes.size(), 0);
      for (const tinygltf::Node& node : model_.nodes)
        for (int c : node.children)
          if (c >= 0 && size_t(c) < model_.nodes.size()) isChild[size_t(c)] = 1;
      for (size_t i = 0; i < model_.nodes.size(); ++i)
        if (!isChild[i]) roots.push_back(int(i));
    }
    checkHierarchy();
    onStack_.assign(model_.nodes.size(), 0);
    for (size_t i = 0; i < roots.size(); ++i) {
      if (roots[i] < 0 || size_t(roots[i]) >= model_.nodes.size())
        fail("scenes[" + std::to_string(model_.defaultScene) + "].nodes[" + std::to_string(i) + "]",
             "node " + std::to_string(roots[i]) + " does not exist (" +
                 std::to_string(model_.nodes.size()) + " nodes)");
      visitTree(size_t(roots[i]));
    }
    if (scene_.indices.empty()) fail("", "the scene has no triangles");
  }

 private:
  [[noreturn]] void fail(const std::string& field, const std::string& problem) const {
    throw FileError(file_, field, problem);
  }

  void convertMaterials() {
    for (size_t i = 0; i < model_.materials.size(); ++i) {
      const tinygltf::Material& src = model_.materials[i];
      const std::string where = indexed("materials", i);
      Material m;
      m.name = src.name.empty() ? where : src.name;
      std::vector<double> base = src.pbrMetallicRoughness.baseColorFactor;
      int albedoTexture = src.pbrMetallicRoughness.baseColorTexture.index;
      int albedoTexCoord = src.pbrMetallicRoughness.baseColorTexture.texCoord;
      std::string albedoWhere = where + ".pbrMetallicRoughness.baseColorTexture";
      // KHR_materials_pbrSpecularGlossiness: the diffuse colour is the Lambertian albedo.
      auto sg = src.extensions.find("KHR_materials_pbrSpecularGlossiness");
      if (sg != src.extensions.end() && sg->second.IsObject()) {
        const std::string sgWhere = where + ".extensions.KHR_materials_pbrSpecularGlossiness";
        base = {1, 1, 1, 1};
        albedoTexture = -1;
        if (sg->second.Has("diffuseFactor")) {
          const tinygltf::Value& f = sg->second.Get("diffuseFactor");
          if (!f.IsArray() || f.ArrayLen() != 4)
            fail(sgWhere + ".diffuseFactor", "expected an array of 4 numbers");
          for (int k = 0; k < 4; ++k) {
            if (!f.Get(k).IsNumber())
              fail(sgWhere + ".diffuseFactor", "expected an array of 4 numbers");
            base[size_t(k)] = f.Get(k).GetNumberAsDouble();
          }
        }
        if (sg->second.Has("diffuseTexture")) {
          const tinygltf::Value& t = sg->second.Get("diffuseTexture");
          if (!t.IsObject() || !t.Has("index") || !t.Get("index").IsNumber())
            fail(sgWhere + ".diffuseTexture", "expected an object with an integer index");
          albedoTexture = t.Get("index").GetNumberAsInt();
          albedoTexCoord = t.Has("texCoord") && t.Get("texCoord").IsNumber()
                               ? t.Get("texCoord").GetNumberAsInt()
                               : 0;
          albedoWhere = sgWhere + ".diffuseTexture";
        }
      }
      if (base.size() >= 3)
        m.albedo = Rgb(std::clamp(base[0], 0.0, 1.0), std::clamp(base[1], 0.0, 1.0),
                       std::clamp(base[2], 0.0, 1.0));
      if (base.size() >= 4) m.alpha = base[3];
      double strength = 1.0;
      auto ext = src.extensions.find("KHR_materials_emissive_strength");
      if (ext != src.extensions.end() && ext->second.Has("emissiveStrength")) {
        const tinygltf::Value& v = ext->second.Get("emissiveStrength");
        if (v.IsNumber()) strength = v.GetNumberAsDouble();
        if (!(strength >= 0) || !std::isfinite(strength))
          fail(where + ".extensions.KHR_materials_emissive_strength.emissiveStrength",
               "expected a finite number >= 0");
      }
      if (src.emissiveFactor.size() >= 3)
        m.emission =
            Rgb(src.emissiveFactor[0], src.emissiveFactor[1], src.emissiveFactor[2]) * strength;
      if (!std::isfinite(m.albedo.maxComponent()) || !std::isfinite(m.emission.maxComponent()) ||
          m.emission.r < 0 || m.emission.g < 0 || m.emission.b < 0 || !std::isfinite(m.alpha))
        fail(where, "colour factors must be finite and non-negative");
      m.doubleSided = src.doubleSided;
      if (src.alphaMode == "MASK") {
        m.alphaMode = AlphaMode::Mask;
        m.alphaCutoff = src.alphaCutoff;
        if (!std::isfinite(m.alphaCutoff) || m.alphaCutoff < 0)
          fail(where + ".alphaCutoff", "expected a finite number >= 0");
      } else if (src.alphaMode == "BLEND") {
        m.alphaMode = AlphaMode::Blend;
      } else if (src.alphaMode != "OPAQUE" && !src.alphaMode.empty()) {
        fail(where + ".alphaMode", "\"" + src.alphaMode + "\", expected OPAQUE, MASK or BLEND");
      }
      m.albedoTexture = textureRef(albedoTexture, albedoTexCoord, albedoWhere);
      if (!m.emission.isBlack())
        m.emissionTexture = textureRef(src.emissiveTexture.index, src.emissiveTexture.texCoord,
                                       where + ".emissiveTexture");
      scene_.materials.push_back(std::move(m));
    }
  }

  void warn(const std::string& field, const std::string& problem) {
    scene_.warnings.push_back(FileError(file_, field, problem).what());
  }

  /// The TextureRef for glTF texture `index` used at `where` (none when index < 0 or the image
  /// cannot be decoded, with a warning: the material keeps its factor).
  TextureRef textureRef(int index, int texCoord, const std::string& where) {
    TextureRef ref;
    if (index < 0) return ref;
    if (size_t(index) >= model_.textures.size())
      fail(where + ".index", "texture " + std::to_string(index) + " does not exist (" +
                                 std::to_string(model_.textures.size()) + " textures)");
    const tinygltf::Texture& tex = model_.textures[size_t(index)];
    const std::string texWhere = indexed("textures", size_t(index));
    if (tex.sampler >= 0) {
      if (size_t(tex.sampler) >= model_.samplers.size())
        fail(texWhere + ".sampler", "sampler " + std::to_string(tex.sampler) + " does not exist (" +
                                        std::to_string(model_.samplers.size()) + " samplers)");
      const tinygltf::Sampler& smp = model_.samplers[size_t(tex.sampler)];
      ref.wrapS = toWrap(smp.wrapS);
      ref.wrapT = toWrap(smp.wrapT);
      ref.nearest = smp.magFilter == TINYGLTF_TEXTURE_FILTER_NEAREST;
    }
    if (tex.source < 0) {
      warn(texWhere, "has no image source; " + where + " falls back to its factor");
      return ref;
    }
    if (size_t(tex.source) >= model_.images.size())
      fail(texWhere + ".source", "image " + std::to_string(tex.source) + " does not exist (" +
                                     std::to_string(model_.images.size()) + " images)");
    if (texCoord != 0)
      warn(where + ".texCoord", "is " + std::to_string(texCoord) +
                                    "; only TEXCOORD_0 is read, the texture is sampled there");
    ref.image = sceneImage(size_t(tex.source), where);
    return ref;
  }

  /// The Scene::images index of glTF image `index`, decoded on first use (colour, sRGB), or -1
  /// with a warning when it cannot be read or decoded.
  int sceneImage(size_t index, const std::string& usedBy) {
    auto it = imageMap_.find(index);
    if (it != imageMap_.end()) return it->second;
    const tinygltf::Image& src = model_.images[index];
    const std::string where = indexed("images", index);
    const bool external = !src.uri.empty() && src.uri.rfind("data:", 0) != 0;
    const std::string named = external ? "\"" + src.uri + "\" " : std::string();
    const std::string fallback = "; " + usedBy + " falls back to its factor";
    int result = -1;
    if (src.image.empty() && src.bufferView >= 0) {
      warn(where, "bufferView " + std::to_string(src.bufferView) + " cannot be read" + fallback);
    } else if (src.image.empty()) {
      warn(where, (external ? named + "cannot be read" : std::string("has no data")) + fallback);
    } else {
      std::string why;
      auto img = decodeImage(src.image.data(), src.image.size(),
                             src.mimeType.empty() ? src.uri : src.mimeType, /*srgb=*/true, why);
      if (!img) {
        warn(where, named + why + fallback);
      } else {
        img->name = where + (external ? " (" + src.uri + ")" : std::string());
        result = int(scene_.images.size());
        scene_.images.push_back(std::move(*img));
      }
    }
    imageMap_[index] = result;
    return result;
  }

  uint32_t defaultMaterialIndex() {
    if (!usesDefaultMaterial_) {
      usesDefaultMaterial_ = true;
      defaultMaterial_ = uint32_t(scene_.materials.size());
      Material m;
      m.name = "default";
      scene_.materials.push_back(m);
    }
    return defaultMaterial_;
  }

  /// glTF 3.5.2: nodes form disjoint strict trees. Child references must exist and no node may
  /// have two parents (which would also let a small file expand exponentially).
  void checkHierarchy() const {
    std::vector<char> hasParent(model_.nodes.size(), 0);
    for (size_t n = 0; n < model_.nodes.size(); ++n) {
      const std::vector<int>& children = model_.nodes[n].children;
      for (size_t c = 0; c < children.size(); ++c) {
        const std::string where = indexed("nodes", n) + ".children[" + std::to_string(c) + "]";
        if (children[c] < 0 || size_t(children[c]) >= model_.nodes.size())
          fail(where, "node " + std::to_string(children[c]) + " does not exist (" +
                          std::to_string(model_.nodes.size()) + " nodes)");
        if (hasParent[size_t(children[c])]++)
          fail(where, "node " + std::to_string(children[c]) +
                          " has more than one parent (the node hierarchy must be a forest)");
      }
    }
  }

  /// Depth-first walk with an explicit stack (hierarchies may be arbitrarily deep).
  void visitTree(size_t root) {
    struct Frame {
      size_t node;
      Mat4 world;
      size_t nextChild;
    };
    std::vector<Frame> stack;
    auto enter = [&](size_t n, const Mat4& parent) {
      if (onStack_[n]) fail(indexed("nodes", n), "the node hierarchy has a cycle");
      onStack_[n] = 1;
      const tinygltf::Node& node = model_.nodes[n];
      const Mat4 world = parent * localTransform(node);
      for (double v : world.m)
        if (!std::isfinite(v)) fail(indexed("nodes", n), "transform is not finite");
      if (node.mesh >= 0) {
        if (size_t(node.mesh) >= model_.meshes.size())
          fail(indexed("nodes", n), "mesh " + std::to_string(node.mesh) + " does not exist (" +
                                        std::to_string(model_.meshes.size()) + " meshes)");
        const tinygltf::Mesh& mesh = model_.meshes[size_t(node.mesh)];
        for (size_t p = 0; p < mesh.primitives.size(); ++p)
          addPrimitive(size_t(node.mesh), p, world);
      }
      addLight(n, world);
      stack.push_back({n, world, 0});
    };
    enter(root, Mat4{});
    while (!stack.empty()) {
      Frame& top = stack.back();
      const std::vector<int>& children = model_.nodes[top.node].children;
      if (top.nextChild < children.size()) {
        const size_t child = size_t(children[top.nextChild++]);
        const Mat4 parent = top.world;  // `top` dies if enter() grows the stack
        enter(child, parent);
      } else {
        onStack_[top.node] = 0;
        stack.pop_back();
      }
    }
  }

  /// Validates accessor `index` (referenced from `user`) and returns a view of it
  /// (spec 3.6.2.4: byteOffset + stride * (count - 1) + elementSize <= bufferView.byteLength).
  AccessorView view(int index, const std::string& user) const {
    if (index < 0 || size_t(index) >= model_.accessors.size())
      fail(user, "accessor " + std::to_string(index) + " does not exist (" +
                     std::to_string(model_.accessors.size()) + " accessors)");
    const std::string where = indexed("accessors", size_t(index));
    const tinygltf::Accessor& acc = model_.accessors[size_t(index)];
    if (acc.sparse.isSparse) fail(where, "sparse accessors are not supported");
    const int componentSize = tinygltf::GetComponentSizeInBytes(uint32_t(acc.componentType));
    const int components = tinygltf::GetNumComponentsInType(uint32_t(acc.type));
    if (componentSize <= 0)
      fail(where, "invalid componentType " + std::to_string(acc.componentType));
    if (components <= 0) fail(where, "invalid type " + std::to_string(acc.type));
    if (acc.bufferView < 0 || size_t(acc.bufferView) >= model_.bufferViews.size())
      fail(where, "bufferView " + std::to_string(acc.bufferView) +
                      " does not exist (accessors without a bufferView are not supported)");
    const std::string viewWhere = indexed("bufferViews", size_t(acc.bufferView));
    const tinygltf::BufferView& bv = model_.bufferViews[size_t(acc.bufferView)];
    if (bv.buffer < 0 || size_t(bv.buffer) >= model_.buffers.size())
      fail(viewWhere, "buffer " + std::to_string(bv.buffer) + " does not exist");
    const tinygltf::Buffer& buf = model_.buffers[size_t(bv.buffer)];
    const uint64_t bufSize = buf.data.size();
    if (bv.byteOffset > bufSize || bv.byteLength > bufSize - bv.byteOffset)
      fail(viewWhere, "byteOffset " + std::to_string(bv.byteOffset) + " + byteLength " +
                          std::to_string(bv.byteLength) + " exceeds the " +
                          std::to_string(bufSize) + " bytes of buffers[" +
                          std::to_string(bv.buffer) + "]");
    const uint64_t elementSize = uint64_t(componentSize) * uint64_t(components);
    const uint64_t stride = bv.byteStride ? bv.byteStride : elementSize;
    if (stride < elementSize)
      fail(viewWhere, "byteStride " + std::to_string(bv.byteStride) +
                          " is smaller than the element size " + std::to_string(elementSize) +
                          " of " + where);
    AccessorView v;
    v.stride = stride;
    v.count = acc.count;
    v.componentType = acc.componentType;
    v.components = components;
    if (acc.count > 0) {
      // Every term is bounded by the view length before multiplying, so nothing overflows.
      const uint64_t len = bv.byteLength;
      const bool fits = acc.byteOffset <= len && elementSize <= len - acc.byteOffset &&
                        (acc.count - 1) <= (len - acc.byteOffset - elementSize) / stride;
      if (!fits)
        fail(where, "byteOffset " + std::to_string(acc.byteOffset) + " + " +
                        std::to_string(acc.count) + " elements of " + std::to_string(elementSize) +
                        " bytes (stride " + std::to_string(stride) + ") exceed " + viewWhere +
                        ".byteLength " + std::to_string(len));
      v.data = buf.data.data() + bv.byteOffset + acc.byteOffset;
    }
    return v;
  }

  static Vec3 readVec3(const AccessorView& v, size_t i) {
    float f[3];
    std::memcpy(f, v.data + i * v.stride, sizeof f);
    return {f[0], f[1], f[2]};
  }

  /// A TEXCOORD element: float, or normalized unsigned byte / short (spec 3.7.2.1).
  static void readTexcoord(const AccessorView& v, size_t i, float out[2]) {
    const unsigned char* p = v.data + i * v.stride;
    switch (v.componentType) {
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        out[0] = p[0] / 255.0f;
        out[1] = p[1] / 255.0f;
        return;
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t u[2];
        std::memcpy(u, p, sizeof u);
        out[0] = u[0] / 65535.0f;
        out[1] = u[1] / 65535.0f;
        return;
      }
      default:
        std::memcpy(out, p, 2 * sizeof(float));
        if (!std::isfinite(out[0])) out[0] = 0;
        if (!std::isfinite(out[1])) out[1] = 0;
    }
  }

  static uint32_t readIndex(const AccessorView& v, size_t i) {
    const unsigned char* p = v.data + i * v.stride;
    switch (v.componentType) {
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE:
        return *p;
      case TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT: {
        uint16_t s;
        std::memcpy(&s, p, sizeof s);
        return s;
      }
      default: {
        uint32_t u;
        std::memcpy(&u, p, sizeof u);
        return u;
      }
    }
  }

  void addPrimitive(size_t meshIndex, size_t primIndex, const Mat4& world) {
    const tinygltf::Primitive& prim = model_.meshes[meshIndex].primitives[primIndex];
    const std::string where =
        indexed("meshes", meshIndex) + ".primitives[" + std::to_string(primIndex) + "]";
    const int mode = prim.mode < 0 ? TINYGLTF_MODE_TRIANGLES : prim.mode;
    if (mode > TINYGLTF_MODE_TRIANGLE_FAN)
      fail(where, "mode " + std::to_string(mode) + " is not a glTF primitive mode (0-6)");
    if (mode < TINYGLTF_MODE_TRIANGLES) return;  // points and lines: no surface
    auto posIt = prim.attributes.find("POSITION");
    if (posIt == prim.attributes.end()) return;  // nothing to render (spec 3.7.2.1)

    // Material.
    uint32_t material;
    if (prim.material < 0) {
      material = defaultMaterialIndex();
    } else if (size_t(prim.material) < model_.materials.size()) {
      material = uint32_t(prim.material);
    } else {
      fail(where, "material " + std::to_string(prim.material) + " does not exist (" +
                      std::to_string(model_.materials.size()) + " materials)");
    }

    // Positions: float VEC3, finite.
    const AccessorView pos = view(posIt->second, where + ".attributes.POSITION");
    if (pos.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT || pos.components != 3)
      fail(where, "POSITION accessor " + std::to_string(posIt->second) +
                      " must be VEC3 of float (componentType 5126), got " +
                      std::to_string(pos.components) + " components of componentType " +
                      std::to_string(pos.componentType));
    const size_t vertexCount = pos.count;
    std::vector<Vec3> localPos(vertexCount);
    for (size_t i = 0; i < vertexCount; ++i) {
      localPos[i] = readVec3(pos, i);
      if (!isFinite(localPos[i])) {
        std::ostringstream s;
        s << "vertex " << i << " is not finite " << localPos[i];
        fail(where, s.str());
      }
    }

    // Normals: used when float VEC3 with one per vertex; otherwise flat normals are computed.
    std::vector<Vec3> localNormal;
    auto norIt = prim.attributes.find("NORMAL");
    if (norIt != prim.attributes.end()) {
      const AccessorView nor = view(norIt->second, where + ".attributes.NORMAL");
      if (nor.count != vertexCount)
        fail(where, "NORMAL has " + std::to_string(nor.count) + " elements, POSITION has " +
                        std::to_string(vertexCount));
      if (nor.componentType == TINYGLTF_COMPONENT_TYPE_FLOAT && nor.components == 3) {
        localNormal.resize(vertexCount);
        for (size_t i = 0; i < vertexCount; ++i) localNormal[i] = readVec3(nor, i);
      }
    }

    // TEXCOORD_0: float, or normalized unsigned byte / short VEC2, one per vertex; (0, 0) when
    // absent.
    std::vector<std::array<float, 2>> localUv(vertexCount, {0.0f, 0.0f});
    auto uvIt = prim.attributes.find("TEXCOORD_0");
    if (uvIt != prim.attributes.end()) {
      const AccessorView uv = view(uvIt->second, where + ".attributes.TEXCOORD_0");
      if (uv.count != vertexCount)
        fail(where, "TEXCOORD_0 has " + std::to_string(uv.count) + " elements, POSITION has " +
                        std::to_string(vertexCount));
      if (uv.components != 2 || (uv.componentType != TINYGLTF_COMPONENT_TYPE_FLOAT &&
                                 uv.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
                                 uv.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT))
        fail(where + ".attributes.TEXCOORD_0",
             "expected VEC2 of float, unsigned byte or unsigned short, got " +
                 std::to_string(uv.components) + " components of componentType " +
                 std::to_string(uv.componentType));
      for (size_t i = 0; i < vertexCount; ++i) readTexcoord(uv, i, localUv[i].data());
    }

    // Vertex list in glTF order (indices or 0..count-1), validated.
    std::vector<uint32_t> order;
    if (prim.indices >= 0) {
      const AccessorView ind = view(prim.indices, where + ".indices");
      if (ind.components != 1 || (ind.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_BYTE &&
                                  ind.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_SHORT &&
                                  ind.componentType != TINYGLTF_COMPONENT_TYPE_UNSIGNED_INT))
        fail(where, "indices accessor " + std::to_string(prim.indices) +
                        " must be SCALAR of unsigned byte, short or int, got componentType " +
                        std::to_string(ind.componentType));
      order.resize(ind.count);
      for (size_t i = 0; i < ind.count; ++i) {
        order[i] = readIndex(ind, i);
        if (order[i] >= vertexCount)
          fail(where, "index " + std::to_string(order[i]) + " out of range (vertex count " +
                          std::to_string(vertexCount) + ")");
      }
    } else {
      if (vertexCount > std::numeric_limits<uint32_t>::max()) fail(where, "too many vertices");
      order.resize(vertexCount);
      for (size_t i = 0; i < vertexCount; ++i) order[i] = uint32_t(i);
    }

    // Triangles in local vertex ids (spec 3.7.2.1 for strip and fan order).
    std::vector<std::array<uint32_t, 3>> tris;
    const size_t n = order.size();
    if (mode == TINYGLTF_MODE_TRIANGLES) {
      for (size_t i = 0; i + 2 < n; i += 3) tris.push_back({order[i], order[i + 1], order[i + 2]});
    } else if (mode == TINYGLTF_MODE_TRIANGLE_STRIP) {
      // p_i = {v_i, v_{i+(1+i%2)}, v_{i+(2-i%2)}}
      for (size_t i = 0; i + 2 < n; ++i)
        tris.push_back({order[i], order[i + 1 + i % 2], order[i + 2 - i % 2]});
    } else {
      // p_i = {v_{i+1}, v_{i+2}, v_0}
      for (size_t i = 0; i + 2 < n; ++i) tris.push_back({order[i + 1], order[i + 2], order[0]});
    }
    if (tris.empty()) return;

    // A negative determinant mirrors: reverse the winding to keep CCW front faces (spec 3.7.4).
    const double det = determinant3(world);
    const bool flip = det < 0;
    if (flip)
      for (auto& t : tris) std::swap(t[1], t[2]);

    const size_t base = scene_.vertexCount();
    if (base + (localNormal.empty() ? 3 * tris.size() : vertexCount) >
        std::numeric_limits<uint32_t>::max())
      fail(where, "the scene has more than 2^32 vertices");

    auto push = [&](Vec3 p, Vec3 nrm, const std::array<float, 2>& uv) {
      scene_.positions.insert(scene_.positions.end(), {float(p.x), float(p.y), float(p.z)});
      scene_.normals.insert(scene_.normals.end(), {float(nrm.x), float(nrm.y), float(nrm.z)});
      scene_.texcoords.insert(scene_.texcoords.end(), {uv[0], uv[1]});
      scene_.bounds.extend(Vec3(float(p.x), float(p.y), float(p.z)));
    };
    std::vector<Vec3> worldPos(vertexCount);
    for (size_t i = 0; i < vertexCount; ++i) {
      worldPos[i] = transformPoint(world, localPos[i]);
      const Vec3 w = worldPos[i];
      if (!std::isfinite(float(w.x)) || !std::isfinite(float(w.y)) || !std::isfinite(float(w.z))) {
        std::ostringstream s;
        s << "vertex " << i << " is not finite in world space (float) " << worldPos[i];
        fail(where, s.str());
      }
    }
    auto faceNormal = [&](const std::array<uint32_t, 3>& t) {
      const Vec3 c = cross(worldPos[t[1]] - worldPos[t[0]], worldPos[t[2]] - worldPos[t[0]]);
      const double len = length(c);
      return len > 0 && std::isfinite(len) ? c / len : Vec3(0, 1, 0);
    };

    if (!localNormal.empty() && det != 0) {
      // Shared vertices; normals by the inverse transpose, renormalized. A zero or non-finite
      // normal in the file is replaced by the normal of the first face that uses the vertex.
      const Mat4 nm = normalMatrix(world, det);
      std::vector<Vec3> worldNormal(vertexCount);
      std::vector<char> bad(vertexCount, 0);
      for (size_t i = 0; i < vertexCount; ++i) {
        const Vec3 v = transformVector(nm, localNormal[i]);
        const double len = length(v);
        if (len > 0 && std::isfinite(len))
          worldNormal[i] = v / len;
        else
          bad[i] = 1;
      }
      for (const auto& t : tris)
        for (uint32_t k : t)
          if (bad[k]) worldNormal[k] = faceNormal(t), bad[k] = 0;
      for (size_t i = 0; i < vertexCount; ++i)
        push(worldPos[i], bad[i] ? Vec3(0, 1, 0) : worldNormal[i], localUv[i]);
      for (const auto& t : tris) {
        scene_.indices.insert(scene_.indices.end(), {uint32_t(base + t[0]), uint32_t(base + t[1]),
                                                     uint32_t(base + t[2])});
        scene_.triangleMaterial.push_back(material);
      }
    } else {
      // Flat normals: three vertices per triangle with the world-space face normal.
      for (const auto& t : tris) {
        const Vec3 nrm = faceNormal(t);
        const uint32_t first = uint32_t(scene_.vertexCount());
        for (uint32_t k : t) push(worldPos[k], nrm, localUv[k]);
        scene_.indices.insert(scene_.indices.end(), {first, first + 1, first + 2});
        scene_.triangleMaterial.push_back(material);
      }
    }
  }

  void addLight(size_t nodeIndex, const Mat4& world) {
    const tinygltf::Node& node = model_.nodes[nodeIndex];
    auto ext = node.extensions.find("KHR_lights_punctual");
    if (ext == node.extensions.end() || !ext->second.Has("light")) return;
    const std::string where = indexed("nodes", nodeIndex) + ".extensions.KHR_lights_punctual";
    const tinygltf::Value& idx = ext->second.Get("light");
    if (!idx.IsNumber()) fail(where, "light must be an integer");
    const double li = idx.GetNumberAsDouble();
    if (!(li >= 0 && li < double(model_.lights.size())))
      fail(where, "light " + std::to_string(li) + " does not exist (" +
                      std::to_string(model_.lights.size()) + " lights)");
    const size_t lightIndex = size_t(li);
    const tinygltf::Light& src = model_.lights[lightIndex];
    const std::string lwhere =
        "extensions.KHR_lights_punctual.lights[" + std::to_string(lightIndex) + "]";
    Light light;
    if (src.type == "directional")
      light.type = LightType::Directional;
    else if (src.type == "point")
      light.type = LightType::Point;
    else if (src.type == "spot")
      light.type = LightType::Spot;
    else
      fail(lwhere, "type \"" + src.type + "\", expected directional, point or spot");
    light.name = src.name.empty() ? indexed("lights", lightIndex) : src.name;
    Rgb color(1, 1, 1);
    if (src.color.size() >= 3) color = Rgb(src.color[0], src.color[1], src.color[2]);
    light.intensity = color * src.intensity;
    if (!std::isfinite(light.intensity.maxComponent()) || light.intensity.r < 0 ||
        light.intensity.g < 0 || light.intensity.b < 0)
      fail(lwhere, "color * intensity must be finite and non-negative");
    light.rangeMeters = src.range > 0 && std::isfinite(src.range) ? src.range : 0.0;
    light.position = transformPoint(world, Vec3(0, 0, 0));
    const Vec3 dir = transformVector(world, Vec3(0, 0, -1));  // lights point along local -Z
    const double len = length(dir);
    if (!(len > 0) || !std::isfinite(len)) fail(where, "the node transform has no direction");
    light.direction = dir / len;
    if (light.type == LightType::Spot) {
      light.innerConeRad = src.spot.innerConeAngle;
      light.outerConeRad = src.spot.outerConeAngle;
      if (!(light.innerConeRad >= 0 && light.innerConeRad < light.outerConeRad &&
            light.outerConeRad <= kPi / 2))
        fail(lwhere + ".spot", "expected 0 <= innerConeAngle < outerConeAngle <= pi/2");
    }
    scene_.lights.push_back(std::move(light));
  }

  const tinygltf::Model& model_;
  std::string file_;
  Scene& scene_;
  std::vector<char> onStack_;
  std::map<size_t, int> imageMap_;  ///< glTF image -> Scene::images index (-1: unreadable)
  bool usesDefaultMaterial_ = false;
  uint32_t defaultMaterial_ = 0;
};

std::vector<unsigned char> readFile(const std::filesystem::path& path, const std::string& file) {
  std::error_code ec;
  if (!std::filesystem::exists(path, ec)) throw FileError(file, "", "file not found");
  if (std::filesystem::is_directory(path, ec))
    throw FileError(file, "", "is a directory, expected a .gltf or .glb file");
  std::ifstream in(path, std::ios::binary);
  if (!in) throw FileError(file, "", "cannot open the file for reading");
  std::vector<unsigned char> bytes((std::istreambuf_iterator<char>(in)),
                                   std::istreambuf_iterator<char>());
  if (in.bad()) throw FileError(file, "", "read error");
  return bytes;
}

uint32_t readU32(const unsigned char* p) {
  return uint32_t(p[0]) | uint32_t(p[1]) << 8 | uint32_t(p[2]) << 16 | uint32_t(p[3]) << 24;
}

/// GLB container checks (spec 4.4) before tinygltf sees the bytes, with a clear message.
void checkGlbHeader(const std::vector<unsigned char>& bytes, const std::string& file) {
  if (bytes.size() < 20)
    throw FileError(file, "",
                    "truncated .glb: " + std::to_string(bytes.size()) +
                        " bytes, shorter than the 20-byte header");
  const uint32_t version = readU32(&bytes[4]);
  const uint32_t length = readU32(&bytes[8]);
  const uint32_t jsonLength = readU32(&bytes[12]);
  const uint32_t jsonType = readU32(&bytes[16]);
  if (version != 2)
    throw FileError(file, "", ".glb version " + std::to_string(version) + ", expected 2");
  if (length > bytes.size())
    throw FileError(file, "",
                    "truncated .glb: header says " + std::to_string(length) +
                        " bytes, the file has " + std::to_string(bytes.size()));
  if (jsonType != 0x4E4F534Au)
    throw FileError(file, "", "malformed .glb: the first chunk is not JSON");
  if (uint64_t(jsonLength) + 20 > length)
    throw FileError(file, "",
                    "truncated .glb: the JSON chunk (" + std::to_string(jsonLength) +
                        " bytes) runs past the end of the file");
  if (uint64_t(jsonLength) + 20 < length) {
    const uint64_t binHeader = uint64_t(jsonLength) + 20;
    if (binHeader + 8 > length)
      throw FileError(file, "", "truncated .glb: incomplete BIN chunk header");
    const uint32_t binLength = readU32(&bytes[binHeader]);
    if (binHeader + 8 + binLength > length)
      throw FileError(file, "",
                      "truncated .glb: the BIN chunk (" + std::to_string(binLength) +
                          " bytes) runs past the end of the file");
  }
}

}  // namespace

Scene loadScene(const std::filesystem::path& path, double metresPerUnit) {
  const std::string file = path.string();
  const std::vector<unsigned char> bytes = readFile(path, file);
  if (bytes.size() > std::numeric_limits<unsigned int>::max())
    throw FileError(file, "", "file larger than 4 GiB");
  const bool binary = bytes.size() >= 4 && std::memcmp(bytes.data(), "glTF", 4) == 0;
  if (binary) checkGlbHeader(bytes, file);

  tinygltf::Model model;
  tinygltf::TinyGLTF gltf;
  gltf.SetImageLoader(&keepEncodedImage, nullptr);
  std::string err, warn;
  std::string baseDir = path.parent_path().string();
  if (baseDir.empty()) baseDir = ".";
  bool ok = false;
  try {
    if (binary)
      ok = gltf.LoadBinaryFromMemory(&model, &err, &warn, bytes.data(),
                                     static_cast<unsigned int>(bytes.size()), baseDir);
    else
      ok =
          gltf.LoadASCIIFromString(&model, &err, &warn, reinterpret_cast<const char*>(bytes.data()),
                                   static_cast<unsigned int>(bytes.size()), baseDir);
  } catch (const std::exception& e) {
    throw FileError(file, "", std::string("not a valid glTF file: ") + oneLine(e.what()));
  }
  if (!ok)
    throw FileError(file, "",
                    std::string(binary ? "not a valid .glb file: " : "not a valid glTF file: ") +
                        (err.empty() ? "unknown tinygltf error" : oneLine(err)));
  for (const std::string& ext : model.extensionsRequired)
    if (ext == "KHR_draco_mesh_compression" || ext == "EXT_meshopt_compression" ||
        ext == "KHR_mesh_quantization")
      throw FileError(file, "extensionsRequired",
                      ext + " is not supported (re-export without mesh compression)");

  Scene scene;
  scene.sourcePath = file;
  Flattener(model, file, scene).run();
  scaleScene(scene, metresPerUnit);
  return scene;
}

}  // namespace ps
