#include "ui/Viewport.h"

// The viewport's OpenGL: its shaders, the GL resources made in initializeGL and freed on
// aboutToBeDestroyed (cleanup), the scene's and the probes' buffers, and each frame (paintGL):
// background and sky, the scene, the probes, the overlays, the sun gizmos and the move handle.

#include <QByteArray>
#include <QOpenGLContext>
#include <algorithm>
#include <cmath>
#include <map>

#include "core/capture/Capture.h"
#include "core/common/Error.h"
#include "core/common/Tolerances.h"
#include "core/scene/Scene.h"
#include "core/trace/Tracer.h"
#include "ui/Document.h"

namespace ps::ui {

namespace {

// ---- shaders (GLSL 3.30 core) ----

const char* kBackgroundVs = R"(#version 330 core
out float vT;
out vec2 vNdc;
void main() {
  vec2 p = vec2((gl_VertexID << 1) & 2, gl_VertexID & 2) * 2.0 - 1.0;  // full-screen triangle
  vT = p.y * 0.5 + 0.5;
  vNdc = p;
  gl_Position = vec4(p, 0.0, 1.0);
})";

// The gradient, or the rig's sky (constant radiance plus its equirectangular map, the
// convention of core/scene/EnvironmentMap.h) seen along each pixel's view ray, tone mapped.
const char* kBackgroundFs = R"(
in float vT;
in vec2 vNdc;
uniform vec3 uTop;
uniform vec3 uBottom;
uniform int uSky;
uniform vec3 uSkyRadiance;
uniform int uEnvOn;
uniform sampler2D uEnv;
uniform mat4 uInvViewProj;
uniform float uExposure;
out vec4 fragColor;
void main() {
  if (uSky == 0) {
    fragColor = vec4(mix(uBottom, uTop, clamp(vT, 0.0, 1.0)), 1.0);
    return;
  }
  vec4 a = uInvViewProj * vec4(vNdc, -1.0, 1.0), b = uInvViewProj * vec4(vNdc, 1.0, 1.0);
  vec3 d = normalize(b.xyz / b.w - a.xyz / a.w);
  vec3 radiance = uSkyRadiance;
  if (uEnvOn == 1) {
    vec2 uv = vec2(0.5 + atan(d.x, -d.z) / 6.28318531, acos(clamp(d.y, -1.0, 1.0)) / 3.14159265);
    radiance += texture(uEnv, uv).rgb;
  }
  fragColor = vec4(linearToSrgb(aces(radiance * uExposure)), 1.0);
})";

const char* kCommonGlsl = R"(
vec3 linearToSrgb(vec3 c) {
  c = clamp(c, 0.0, 1.0);
  return mix(c * 12.92, 1.055 * pow(c, vec3(1.0 / 2.4)) - 0.055, step(vec3(0.0031308), c));
}
// ACES filmic fit (Narkowicz 2015).
vec3 aces(vec3 x) { return clamp((x * (2.51 * x + 0.03)) / (x * (2.43 * x + 0.59) + 0.14), 0.0, 1.0); }
)";

const char* kSceneVs = R"(#version 330 core
layout(location = 0) in vec3 aPos;
layout(location = 1) in vec3 aNormal;
uniform mat4 uViewProj;
out vec3 vWorld;
out vec3 vNormal;
void main() {
  vWorld = aPos;
  vNormal = aNormal;
  gl_Position = uViewProj * vec4(aPos, 1.0);
})";

const char* kSceneFs = R"(
in vec3 vWorld;
in vec3 vNormal;
uniform samplerBuffer uMaterials;     // 2 texels per material: albedo, emission
uniform usamplerBuffer uTriMaterial;  // material index per triangle
uniform vec3 uEye;
uniform float uClipY;  // cut-away: nothing above this height is drawn
uniform int uCaps;     // 1: back faces are the insides of closed solids cut open: draw as caps
uniform int uPreview;  // 1: lit by an SH irradiance grid (the probes', or the scene lights')
uniform sampler3D uSh0, uSh1, uSh2, uSh3, uSh4, uSh5, uSh6;  // 27 floats A_l c_lm per cell
uniform vec3 uGridLo;
uniform vec3 uGridSize;
uniform float uExposure;
out vec4 fragColor;
// Irradiance E(n) = sum A_l c_lm Y_lm(n) (Ramamoorthi & Hanrahan 2001) from the grid, trilinear.
vec3 gridIrradiance(vec3 p, vec3 n) {
  vec3 t = clamp((p - uGridLo) / uGridSize, 0.0, 1.0);
  vec4 s0 = texture(uSh0, t), s1 = texture(uSh1, t), s2 = texture(uSh2, t), s3 = texture(uSh3, t);
  vec4 s4 = texture(uSh4, t), s5 = texture(uSh5, t), s6 = texture(uSh6, t);
  float f[28] = float[28](s0.x, s0.y, s0.z, s0.w, s1.x, s1.y, s1.z, s1.w, s2.x, s2.y, s2.z, s2.w,
                          s3.x, s3.y, s3.z, s3.w, s4.x, s4.y, s4.z, s4.w, s5.x, s5.y, s5.z, s5.w,
                          s6.x, s6.y, s6.z, s6.w);
  float x = n.x, y = n.y, z = n.z;
  float Y[9] = float[9](0.282095, 0.488603 * y, 0.488603 * z, 0.488603 * x, 1.092548 * x * y,
                        1.092548 * y * z, 0.315392 * (3.0 * z * z - 1.0), 1.092548 * x * z,
                        0.546274 * (x * x - y * y));
  vec3 e = vec3(0.0);
  for (int i = 0; i < 9; ++i) e += vec3(f[3 * i], f[3 * i + 1], f[3 * i + 2]) * Y[i];
  return e;
}
void main() {
  if (vWorld.y > uClipY) discard;
  if (uCaps == 1 && !gl_FrontFacing) {
    fragColor = vec4(0.16, 0.15, 0.14, 1.0);
    return;
  }
  uint m = texelFetch(uTriMaterial, gl_PrimitiveID).r;
  vec3 albedo = texelFetch(uMaterials, int(2u * m)).rgb;
  vec3 emission = texelFetch(uMaterials, int(2u * m + 1u)).rgb;
  vec3 n = normalize(vNormal);
  if (!gl_FrontFacing) n = -n;
  vec3 v = normalize(uEye - vWorld);
  if (uPreview == 1) {
    vec3 e = max(gridIrradiance(vWorld, n), 0.0);
    vec3 lit = aces((albedo * e / 3.14159265 + emission) * uExposure);
    fragColor = vec4(linearToSrgb(lit), 1.0);
    return;
  }
  vec3 key = normalize(vec3(0.35, 1.0, 0.55));
  // Display-referred preview lighting: ambient + headlight + a fixed key light from above.
  float light = 0.18 + 0.52 * max(dot(n, v), 0.0) + 0.30 * max(dot(n, key), 0.0);
  vec3 c = albedo * light + emission / (1.0 + emission) * 0.6;
  fragColor = vec4(linearToSrgb(c), 1.0);
})";

const char* kProbeVs = R"(#version 330 core
layout(location = 0) in vec3 aPos;        // unit sphere; also the normal
layout(location = 1) in vec4 iPosRadius;  // centre, drawn radius
layout(location = 2) in vec4 iStyle;      // state (0 candidate, 1 accepted, 2 rejected), selected, hasSh, alpha
uniform mat4 uViewProj;
uniform int uImpostor;  // 1: aPos.xy is a quad corner; the sphere is ray cast per fragment
uniform vec3 uRight;
uniform vec3 uUp;
uniform vec3 uEye;
uniform vec3 uForward;
// Probes show at least this radius in pixels (times their state's factor): the radius is scaled
// by max(1, uMinRadiusScale * depth), uMinRadiusScale = minimum pixels * metres per pixel at unit
// depth / the base radius (Viewport::drawnRadius).
uniform float uMinRadiusScale;
out vec3 vWorld;
out vec3 vNormal;
flat out vec4 vStyle;
flat out int vInstance;  // the SH is fetched from the instance buffer (few varyings: fast)
flat out vec4 vSphere;
void main() {
  vNormal = aPos;
  float depth = max(dot(iPosRadius.xyz - uEye, uForward), 0.0);
  vSphere = vec4(iPosRadius.xyz, iPosRadius.w * max(1.0, uMinRadiusScale * depth));
  if (uImpostor == 1)  // a camera-facing quad large enough for the perspective silhouette
    vWorld = vSphere.xyz + (uRight * aPos.x + uUp * aPos.y) * (vSphere.w * 1.6);
  else
    vWorld = vSphere.xyz + aPos * vSphere.w;
  vStyle = iStyle;
  vInstance = gl_InstanceID;
  gl_Position = uViewProj * vec4(vWorld, 1.0);
})";

const char* kProbeFs = R"(
in vec3 vWorld;
in vec3 vNormal;
flat in vec4 vStyle;
flat in int vInstance;
flat in vec4 vSphere;
uniform samplerBuffer uInstances;  // the instance buffer: 9 RGBA texels per probe, SH from 2
uniform vec3 uEye;
uniform float uExposure;
uniform int uXray;  // 1 = pass drawing the parts hidden behind geometry
uniform int uImpostor;
uniform mat4 uViewProj;
out vec4 fragColor;
vec4 vSh[7];
float shf(int k) { return vSh[k / 4][k % 4]; }
vec3 shc(int i) { return vec3(shf(3 * i), shf(3 * i + 1), shf(3 * i + 2)); }
// Irradiance E(n) = sum A_l c_lm Y_lm(n) (Ramamoorthi & Hanrahan 2001); basis as core/math/Sh.cpp.
vec3 irradiance(vec3 n) {
  float x = n.x, y = n.y, z = n.z;
  return shc(0) * 0.282095 + shc(1) * (0.488603 * y) + shc(2) * (0.488603 * z) +
         shc(3) * (0.488603 * x) + shc(4) * (1.092548 * x * y) + shc(5) * (1.092548 * y * z) +
         shc(6) * (0.315392 * (3.0 * z * z - 1.0)) + shc(7) * (1.092548 * x * z) +
         shc(8) * (0.546274 * (x * x - y * y));
}
void main() {
  for (int i = 0; i < 7; ++i) vSh[i] = texelFetch(uInstances, vInstance * 9 + 2 + i);
  vec3 n = normalize(vNormal);
  vec3 world = vWorld;
  if (uImpostor == 1) {
    // Ray from the eye through this fragment against the probe's sphere.
    vec3 d = normalize(vWorld - uEye), oc = uEye - vSphere.xyz;
    float b = dot(oc, d), c = dot(oc, oc) - vSphere.w * vSphere.w, disc = b * b - c;
    if (disc < 0.0) discard;
    world = uEye + d * (-b - sqrt(disc));
    n = normalize(world - vSphere.xyz);
    vec4 clip = uViewProj * vec4(world, 1.0);
    gl_FragDepth = clamp(clip.z / clip.w * 0.5 + 0.5, 0.0, 1.0);
  } else {
    gl_FragDepth = gl_FragCoord.z;
  }
  vec3 v = normalize(uEye - world);
  float facing = max(dot(n, v), 0.0);
  int code = int(vStyle.x + 0.5);
  int state = code & 7;
  bool invalid = code >= 8;  // inside geometry (Kontkanen & Laine sec. 5)
  bool selected = vStyle.y > 0.5;
  vec3 c;
  if (vStyle.z > 0.5) {
    // A white Lambertian sphere lit by the probe: radiance E(n) / pi, tone mapped.
    c = aces(max(irradiance(n), 0.0) / 3.14159265 * uExposure);
  } else {
    c = vec3(0.42) * (0.35 + 0.65 * facing);  // not captured: neutral grey
  }
  if (state == 2) c = mix(vec3(dot(c, vec3(0.333))), vec3(0.25), 0.5);  // rejected: faded
  // Outline ring so every probe reads against any background.
  vec3 ring = state == 1 ? vec3(0.95) : (state == 0 ? vec3(1.0, 0.72, 0.18) : vec3(0.75, 0.25, 0.2));
  float ringWidth = 0.42;
  if (selected) { ring = vec3(0.15, 0.95, 1.0); ringWidth = 0.6; }
  if (invalid) {
    // Magenta ring and a cross over the sphere.
    ring = vec3(1.0, 0.1, 0.85);
    ringWidth = 0.55;
    vec3 q = (world - vSphere.xyz) / vSphere.w;
    vec3 r = normalize(cross(uEye - vSphere.xyz, vec3(0.0, 1.0, 0.0)) + vec3(1e-6));
    vec3 u = normalize(cross(r, uEye - vSphere.xyz));
    float a = dot(q, r), b = dot(q, u);
    if (min(abs(a - b), abs(a + b)) < 0.16) c = ring;
  }
  float edge = smoothstep(ringWidth, ringWidth - 0.1, facing);
  c = mix(c, ring, edge);
  float alpha = vStyle.w;
  // Hidden parts are ghosts, except for probes inside geometry: they are always hidden, and shown.
  if (uXray == 1 && !invalid) alpha *= mix(0.18, 0.7, edge);
  fragColor = vec4(linearToSrgb(c), alpha);
})";

const char* kLineVs = R"(#version 330 core
layout(location = 0) in vec3 aPos;
layout(location = 1) in vec4 aColor;
uniform mat4 uViewProj;
out vec4 vColor;
void main() {
  vColor = aColor;
  gl_Position = uViewProj * vec4(aPos, 1.0);
})";

const char* kLineFs = R"(#version 330 core
in vec4 vColor;
out vec4 fragColor;
void main() { fragColor = vColor; })";

/// True when at least 90% of the edges (vertices welded by position) are shared by exactly two
/// triangles: the scene is made of closed solids, whose back faces are never seen uncut.
bool isMostlyClosed(const Scene& scene) {
  std::map<std::array<int64_t, 3>, uint32_t> weld;
  std::vector<uint32_t> welded(scene.vertexCount());
  const double q = 1e4 / std::max(scene.bounds.diagonal(), 1e-9);
  for (uint32_t i = 0; i < welded.size(); ++i) {
    const Vec3 v = scene.vertex(i) * q;
    const std::array<int64_t, 3> key{std::llround(v.x), std::llround(v.y), std::llround(v.z)};
    welded[i] = weld.emplace(key, uint32_t(weld.size())).first->second;
  }
  std::map<std::pair<uint32_t, uint32_t>, int> edges;
  for (size_t t = 0; t + 2 < scene.indices.size(); t += 3)
    for (int e = 0; e < 3; ++e) {
      uint32_t a = welded[scene.indices[t + e]], b = welded[scene.indices[t + (e + 1) % 3]];
      if (a > b) std::swap(a, b);
      ++edges[{a, b}];
    }
  size_t paired = 0;
  for (const auto& [edge, count] : edges) paired += count == 2;
  return !edges.empty() && paired >= 0.9 * double(edges.size());
}

constexpr int kInstanceFloats = 36;
constexpr GLsizei kMaxXrayProbes = 2000;

}  // namespace

GLuint Viewport::buildProgram(const char* vs, const char* fsBody, bool common) {
  auto compile = [this](GLenum type, const QByteArray& src) {
    const GLuint s = glCreateShader(type);
    const char* p = src.constData();
    glShaderSource(s, 1, &p, nullptr);
    glCompileShader(s);
    GLint ok = 0;
    glGetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
      char log[4096];
      glGetShaderInfoLog(s, sizeof log, nullptr, log);
      qFatal("viewport shader failed to compile: %s", log);
    }
    return s;
  };
  QByteArray fs =
      common ? QByteArray("#version 330 core\n") + kCommonGlsl + fsBody : QByteArray(fsBody);
  const GLuint v = compile(GL_VERTEX_SHADER, vs), f = compile(GL_FRAGMENT_SHADER, fs);
  const GLuint prog = glCreateProgram();
  glAttachShader(prog, v);
  glAttachShader(prog, f);
  glLinkProgram(prog);
  glDeleteShader(v);
  glDeleteShader(f);
  GLint ok = 0;
  glGetProgramiv(prog, GL_LINK_STATUS, &ok);
  if (!ok) {
    char log[4096];
    glGetProgramInfoLog(prog, sizeof log, nullptr, log);
    qFatal("viewport shader failed to link: %s", log);
  }
  return prog;
}

void Viewport::initializeGL() {
  if (!context() || !context()->isValid()) return;
  connect(context(), &QOpenGLContext::aboutToBeDestroyed, this, &Viewport::cleanup);
  initializeOpenGLFunctions();

  backgroundProgram_ = buildProgram(kBackgroundVs, kBackgroundFs, true);
  sceneProgram_ = buildProgram(kSceneVs, kSceneFs, true);
  probeProgram_ = buildProgram(kProbeVs, kProbeFs, true);
  lineProgram_ = buildProgram(kLineVs, kLineFs, false);
  glGenVertexArrays(1, &lineVao_);
  glGenBuffers(1, &lineVbo_);
  glBindVertexArray(lineVao_);
  glBindBuffer(GL_ARRAY_BUFFER, lineVbo_);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 7 * sizeof(float), nullptr);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 4, GL_FLOAT, GL_FALSE, 7 * sizeof(float),
                        reinterpret_cast<const void*>(3 * sizeof(float)));
  glBindVertexArray(0);

  glGenVertexArrays(1, &emptyVao_);
  glGenTextures(1, &envTex_);
  glBindTexture(GL_TEXTURE_2D, envTex_);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_S, GL_REPEAT);
  glTexParameteri(GL_TEXTURE_2D, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
  glBindTexture(GL_TEXTURE_2D, 0);
  envKey_.clear();

  // Scene buffers (filled in uploadScene).
  glGenVertexArrays(1, &sceneVao_);
  glGenBuffers(3, sceneVbo_);
  glGenBuffers(1, &materialTbo_);
  glGenTextures(1, &materialTex_);
  glGenBuffers(1, &triMaterialTbo_);
  glGenTextures(1, &triMaterialTex_);

  // Unit UV sphere, counter-clockwise seen from outside.
  const int rings = 16, segs = 28;
  std::vector<float> verts;
  std::vector<uint32_t> idx;
  for (int i = 0; i <= rings; ++i) {
    const double th = kPi * i / rings;
    for (int j = 0; j <= segs; ++j) {
      const double ph = 2 * kPi * j / segs;
      verts.insert(verts.end(), {float(std::sin(th) * std::cos(ph)), float(std::cos(th)),
                                 float(std::sin(th) * std::sin(ph))});
    }
  }
  for (int i = 0; i < rings; ++i)
    for (int j = 0; j < segs; ++j) {
      const uint32_t a = uint32_t(i * (segs + 1) + j), b = a + uint32_t(segs + 1);
      idx.insert(idx.end(), {a, a + 1, b, a + 1, b + 1, b});
    }
  sphereIndexCount_ = GLsizei(idx.size());
  glGenVertexArrays(1, &sphereVao_);
  glGenBuffers(1, &sphereVbo_);
  glGenBuffers(1, &sphereIbo_);
  glGenBuffers(1, &instanceVbo_);
  glBindVertexArray(sphereVao_);
  glBindBuffer(GL_ARRAY_BUFFER, sphereVbo_);
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(verts.size() * sizeof(float)), verts.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, sphereIbo_);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(idx.size() * sizeof(uint32_t)), idx.data(),
               GL_STATIC_DRAW);
  glBindBuffer(GL_ARRAY_BUFFER, instanceVbo_);
  for (int a = 0; a < 2; ++a) {
    glEnableVertexAttribArray(GLuint(1 + a));
    glVertexAttribPointer(GLuint(1 + a), 4, GL_FLOAT, GL_FALSE, kInstanceFloats * sizeof(float),
                          reinterpret_cast<const void*>(size_t(a) * 4 * sizeof(float)));
    glVertexAttribDivisor(GLuint(1 + a), 1);
  }
  glBindVertexArray(0);

  // Impostor quad (triangle strip) with the same per-instance attributes.
  const float quad[] = {-1, -1, 0, 1, -1, 0, -1, 1, 0, 1, 1, 0};
  glGenTextures(1, &instanceTex_);
  glGenVertexArrays(1, &impostorVao_);
  glGenBuffers(1, &quadVbo_);
  glBindVertexArray(impostorVao_);
  glBindBuffer(GL_ARRAY_BUFFER, quadVbo_);
  glBufferData(GL_ARRAY_BUFFER, sizeof quad, quad, GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
  glBindBuffer(GL_ARRAY_BUFFER, instanceVbo_);
  for (int a = 0; a < 2; ++a) {  // centre + radius, style; the SH is read as a texture buffer
    glEnableVertexAttribArray(GLuint(1 + a));
    glVertexAttribPointer(GLuint(1 + a), 4, GL_FLOAT, GL_FALSE, kInstanceFloats * sizeof(float),
                          reinterpret_cast<const void*>(size_t(a) * 4 * sizeof(float)));
    glVertexAttribDivisor(GLuint(1 + a), 1);
  }
  glBindVertexArray(0);

  initOverlayGL();
  glReady_ = true;
  sceneDirty_ = probesDirty_ = overlaysDirty_ = true;
}

void Viewport::cleanup() {
  if (!glReady_) return;
  makeCurrent();
  glDeleteProgram(backgroundProgram_);
  glDeleteProgram(sceneProgram_);
  glDeleteProgram(probeProgram_);
  cleanupOverlayGL();
  glDeleteProgram(lineProgram_);
  glDeleteVertexArrays(1, &lineVao_);
  glDeleteBuffers(1, &lineVbo_);
  glDeleteVertexArrays(1, &emptyVao_);
  glDeleteTextures(1, &envTex_);
  glDeleteVertexArrays(1, &sceneVao_);
  glDeleteBuffers(3, sceneVbo_);
  glDeleteBuffers(1, &materialTbo_);
  glDeleteTextures(1, &materialTex_);
  glDeleteBuffers(1, &triMaterialTbo_);
  glDeleteTextures(1, &triMaterialTex_);
  glDeleteVertexArrays(1, &sphereVao_);
  glDeleteBuffers(1, &sphereVbo_);
  glDeleteBuffers(1, &sphereIbo_);
  glDeleteBuffers(1, &instanceVbo_);
  glDeleteVertexArrays(1, &impostorVao_);
  glDeleteTextures(1, &instanceTex_);
  glDeleteBuffers(1, &quadVbo_);
  glReady_ = false;
  doneCurrent();
}

void Viewport::uploadEnvironment() {
  const LightingRig& rig = doc_->probeSet().rig;
  const std::string key =
      rig.envMapPath + '|' + std::to_string(reinterpret_cast<uintptr_t>(rig.envMap.get()));
  if (key == envKey_) return;
  envKey_ = key;
  env_.reset();
  envMeanLuminance_ = 0;
  try {
    env_ = environmentOf(rig);
  } catch (const Error&) {
    env_.reset();  // the Lighting tab and the capture report an unreadable map
  }
  if (!env_ || env_->width < 1 || env_->height < 1) return;
  double sum = 0, solidAngle = 0;
  for (int row = 0; row < env_->height; ++row) {
    const double w = env_->texelSolidAngle(row);
    for (int col = 0; col < env_->width; ++col) {
      const float* t = &env_->rgb[3 * (size_t(row) * size_t(env_->width) + size_t(col))];
      sum += w * luminance(Rgb(t[0], t[1], t[2]));
      solidAngle += w;
    }
  }
  envMeanLuminance_ = solidAngle > 0 ? sum / solidAngle : 0;
  glBindTexture(GL_TEXTURE_2D, envTex_);
  glTexImage2D(GL_TEXTURE_2D, 0, GL_RGB32F, env_->width, env_->height, 0, GL_RGB, GL_FLOAT,
               env_->rgb.data());
  glBindTexture(GL_TEXTURE_2D, 0);
}

void Viewport::uploadScene() {
  sceneDirty_ = false;
  const Scene* scene = doc_->scene();
  sceneIndexCount_ = 0;
  if (!scene || scene->indices.empty()) return;
  glBindVertexArray(sceneVao_);
  glBindBuffer(GL_ARRAY_BUFFER, sceneVbo_[0]);
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(scene->positions.size() * sizeof(float)),
               scene->positions.data(), GL_STATIC_DRAW);
  glEnableVertexAttribArray(0);
  glVertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  glBindBuffer(GL_ARRAY_BUFFER, sceneVbo_[1]);
  std::vector<float> normals = scene->normals;
  normals.resize(scene->positions.size(), 0.0f);
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(normals.size() * sizeof(float)), normals.data(),
               GL_STATIC_DRAW);
  glEnableVertexAttribArray(1);
  glVertexAttribPointer(1, 3, GL_FLOAT, GL_FALSE, 0, nullptr);
  glBindBuffer(GL_ELEMENT_ARRAY_BUFFER, sceneVbo_[2]);
  glBufferData(GL_ELEMENT_ARRAY_BUFFER, GLsizeiptr(scene->indices.size() * sizeof(uint32_t)),
               scene->indices.data(), GL_STATIC_DRAW);
  glBindVertexArray(0);
  sceneIndexCount_ = GLsizei(scene->indices.size());
  sceneClosed_ = isMostlyClosed(*scene);

  std::vector<float> mats;
  for (const Material& m : scene->materials)
    mats.insert(mats.end(), {float(m.albedo.r), float(m.albedo.g), float(m.albedo.b), 1.0f,
                             float(m.emission.r), float(m.emission.g), float(m.emission.b), 0.0f});
  if (mats.empty()) mats = {0.8f, 0.8f, 0.8f, 1, 0, 0, 0, 0};
  const uint32_t materialCount = uint32_t(mats.size() / 8);
  std::vector<uint32_t> triMat(scene->triangleCount(), 0);
  for (size_t i = 0; i < triMat.size() && i < scene->triangleMaterial.size(); ++i)
    triMat[i] = std::min(scene->triangleMaterial[i], materialCount - 1);
  glBindBuffer(GL_TEXTURE_BUFFER, materialTbo_);
  glBufferData(GL_TEXTURE_BUFFER, GLsizeiptr(mats.size() * sizeof(float)), mats.data(),
               GL_STATIC_DRAW);
  glBindTexture(GL_TEXTURE_BUFFER, materialTex_);
  glTexBuffer(GL_TEXTURE_BUFFER, GL_RGBA32F, materialTbo_);
  glBindBuffer(GL_TEXTURE_BUFFER, triMaterialTbo_);
  glBufferData(GL_TEXTURE_BUFFER, GLsizeiptr(triMat.size() * sizeof(uint32_t)), triMat.data(),
               GL_STATIC_DRAW);
  glBindTexture(GL_TEXTURE_BUFFER, triMaterialTex_);
  glTexBuffer(GL_TEXTURE_BUFFER, GL_R32UI, triMaterialTbo_);
  glBindBuffer(GL_TEXTURE_BUFFER, 0);
  glBindTexture(GL_TEXTURE_BUFFER, 0);
}

bool Viewport::isInvalid(const Probe& p) const {
  const Tracer* tracer = doc_->tracer();
  if (!tracer) return false;
  auto it = validity_.find(p.id);
  if (it != validity_.end() && it->second.first == p.position) return it->second.second;
  // Kontkanen & Laine sec. 5: inside geometry when too many rays hit back faces.
  const bool invalid =
      backfaceFraction(*tracer, p.position, 32, 1) > tol::kDefaultInvalidBackfaceFraction;
  validity_[p.id] = {p.position, invalid};
  return invalid;
}

void Viewport::uploadProbes() {
  probesDirty_ = false;
  std::vector<float> inst;
  const auto& probes = doc_->probes();
  inst.reserve(probes.size() * kInstanceFloats);
  GLsizei count = 0;
  for (const Probe& p : probes) {
    if (!isDrawn(p) && probesVisible_) continue;
    ++count;
    const bool selected = selection_.contains(p.id);
    const float alpha = p.state == ProbeState::Rejected && !selected ? 0.45f : 1.0f;
    const float code = float(int(p.state) + (isInvalid(p) ? 8 : 0));  // state, +8: invalid
    inst.insert(inst.end(),
                {float(p.position.x), float(p.position.y), float(p.position.z), worldRadius(p),
                 code, selected ? 1.0f : 0.0f, p.sh ? 1.0f : 0.0f, alpha});
    for (int i = 0; i < kShCoeffCount; ++i) {
      const Rgb c = p.sh ? p.sh->c[size_t(i)] * shCosineLobe(i) : Rgb();
      inst.insert(inst.end(), {float(c.r), float(c.g), float(c.b)});
    }
    inst.push_back(0.0f);
  }
  instanceCount_ = count;
  if (inst.empty()) inst.assign(kInstanceFloats, 0.0f);  // a texture buffer needs storage
  glBindBuffer(GL_ARRAY_BUFFER, instanceVbo_);
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(inst.size() * sizeof(float)), inst.data(),
               GL_DYNAMIC_DRAW);
  glBindBuffer(GL_ARRAY_BUFFER, 0);
  glBindTexture(GL_TEXTURE_BUFFER, instanceTex_);
  glTexBuffer(GL_TEXTURE_BUFFER, GL_RGBA32F, instanceVbo_);
  glBindTexture(GL_TEXTURE_BUFFER, 0);
}

void Viewport::resizeGL(int, int) {
  if (framePending_) frameAll();
}

void Viewport::paintGL() {
  if (!glReady_) return;  // no context (e.g. a platform without OpenGL)
  if (framePending_) frameAll();
  if (sceneDirty_) uploadScene();
  if (probesDirty_) uploadProbes();
  // Fields are rebuilt from the probes in the background when an edit ends (not on every step
  // of a drag) and once a moved probe's quick capture (milliseconds) has landed, so that one
  // rebuild shows it; the frame shows the previous ones until then.
  if ((previewLighting_ || overlays_) && drag_ != Drag::Handle && !doc_->isQuickCapturePending())
    startFieldsRebuild();
  // The scene's own light is computed when the view falls back to it (no probe lighting).
  if (!flatShading_ && !(previewLighting_ && previewVolume_ && previewGrid_.size() > 0))
    startSceneLightRebuild();
  if (shading() != uploadedShading_) overlaysDirty_ = true;
  if (overlaysDirty_) uploadOverlays();
  if (sliceTexDirty_ && overlay(Overlay::Slice)) uploadSliceTexture();
  if (meteredVersion_ != lightingVersion_ || meteredSize_ != size() ||
      meteredView_ != viewProjection())
    meterExposureNow();

  glClearColor(0, 0, 0, 1);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);

  // Background gradient.
  glDisable(GL_DEPTH_TEST);
  glDepthMask(GL_FALSE);
  glDisable(GL_BLEND);
  glUseProgram(backgroundProgram_);
  const QColor top = backgroundTop(), bottom = backgroundBottom();
  glUniform3f(glGetUniformLocation(backgroundProgram_, "uTop"), float(top.redF()),
              float(top.greenF()), float(top.blueF()));
  glUniform3f(glGetUniformLocation(backgroundProgram_, "uBottom"), float(bottom.redF()),
              float(bottom.greenF()), float(bottom.blueF()));
  const QMatrix4x4 vp = viewProjection();
  {
    // The rig's sky behind the scene, at the view's exposure but dimmed so that its mean stays
    // below white (kSkyDisplayMax): the rooms set the exposure, and a sky many times brighter
    // than they are would otherwise fill the frame with white.
    uploadEnvironment();
    const Rgb sky = doc_->probeSet().rig.skyRadiance;
    const double skyLuminance = luminance(sky) + (env_ ? envMeanLuminance_ : 0.0);
    const bool showSky = skyLuminance > 0;
    constexpr double kSkyDisplayMax = 0.35;  // ACES gives 0.49 linear, 186 in 8-bit sRGB
    const double skyExposure =
        showSky ? std::min(double(exposure()), kSkyDisplayMax / skyLuminance) : 1.0;
    glUniform1i(glGetUniformLocation(backgroundProgram_, "uSky"), showSky ? 1 : 0);
    glUniform3f(glGetUniformLocation(backgroundProgram_, "uSkyRadiance"), float(sky.r),
                float(sky.g), float(sky.b));
    glUniform1i(glGetUniformLocation(backgroundProgram_, "uEnvOn"), env_ ? 1 : 0);
    glUniform1f(glGetUniformLocation(backgroundProgram_, "uExposure"), float(skyExposure));
    glUniformMatrix4fv(glGetUniformLocation(backgroundProgram_, "uInvViewProj"), 1, GL_FALSE,
                       vp.inverted().constData());
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_2D, envTex_);
    glUniform1i(glGetUniformLocation(backgroundProgram_, "uEnv"), 0);
  }
  glBindVertexArray(emptyVao_);
  glDrawArrays(GL_TRIANGLES, 0, 3);
  glBindTexture(GL_TEXTURE_2D, 0);

  const QVector3D eye = camera_.eye();
  glEnable(GL_DEPTH_TEST);
  glDepthMask(GL_TRUE);
  glDepthFunc(GL_LESS);

  // Scene. The cut-away removes everything above a height (ceilings, wall tops) so the camera
  // looks into the rooms. Closed solids (walls with thickness) show their cut as dark caps
  // (their back faces); in open, single-sided geometry back faces are culled instead, so walls
  // seen from outside vanish too.
  if (sceneIndexCount_ > 0) {
    const bool caps = cutaway_ && sceneClosed_;
    if (cutaway_ && !sceneClosed_) {
      glEnable(GL_CULL_FACE);
      glCullFace(GL_BACK);
    } else {
      glDisable(GL_CULL_FACE);
    }
    glUseProgram(sceneProgram_);
    glUniform1f(glGetUniformLocation(sceneProgram_, "uClipY"),
                cutaway_ ? cutHeight() : std::numeric_limits<float>::max());
    glUniform1i(glGetUniformLocation(sceneProgram_, "uCaps"), caps ? 1 : 0);
    glUniformMatrix4fv(glGetUniformLocation(sceneProgram_, "uViewProj"), 1, GL_FALSE,
                       vp.constData());
    glUniform3f(glGetUniformLocation(sceneProgram_, "uEye"), eye.x(), eye.y(), eye.z());
    const ShGrid* lightGrid = shadingGrid();
    const bool preview = lightGrid && previewTexValid_;
    glUniform1i(glGetUniformLocation(sceneProgram_, "uPreview"), preview ? 1 : 0);
    glUniform1f(glGetUniformLocation(sceneProgram_, "uExposure"), exposure());
    const ShGrid& g = lightGrid ? *lightGrid : previewGrid_;
    const Vec3 gridSize(g.dims[0] * g.cellMeters.x, g.dims[1] * g.cellMeters.y,
                        g.dims[2] * g.cellMeters.z);
    glUniform3f(glGetUniformLocation(sceneProgram_, "uGridLo"), float(g.lo.x), float(g.lo.y),
                float(g.lo.z));
    glUniform3f(glGetUniformLocation(sceneProgram_, "uGridSize"), float(std::max(gridSize.x, 1e-6)),
                float(std::max(gridSize.y, 1e-6)), float(std::max(gridSize.z, 1e-6)));
    for (int i = 0; i < 7; ++i) {
      glActiveTexture(GLenum(GL_TEXTURE2 + i));
      glBindTexture(GL_TEXTURE_3D, previewTex_[i]);
      const QByteArray name = "uSh" + QByteArray::number(i);
      glUniform1i(glGetUniformLocation(sceneProgram_, name.constData()), 2 + i);
    }
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_BUFFER, materialTex_);
    glUniform1i(glGetUniformLocation(sceneProgram_, "uMaterials"), 0);
    glActiveTexture(GL_TEXTURE1);
    glBindTexture(GL_TEXTURE_BUFFER, triMaterialTex_);
    glUniform1i(glGetUniformLocation(sceneProgram_, "uTriMaterial"), 1);
    glBindVertexArray(sceneVao_);
    glDrawElements(GL_TRIANGLES, sceneIndexCount_, GL_UNSIGNED_INT, nullptr);
    glActiveTexture(GL_TEXTURE0);
  }

  // Probes: a visible pass, then an x-ray pass that ghosts the parts hidden behind geometry.
  if (probesVisible_ && instanceCount_ > 0) {
    glEnable(GL_CULL_FACE);
    glCullFace(GL_BACK);
    glEnable(GL_BLEND);
    // "Over" on alpha too: the framebuffer stays opaque. With plain glBlendFunc its alpha drops
    // under translucent strokes and the window composes (and grabs) them as invalid
    // premultiplied colour (orange lines would show green in a window screenshot).
    glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
    glUseProgram(probeProgram_);
    glUniformMatrix4fv(glGetUniformLocation(probeProgram_, "uViewProj"), 1, GL_FALSE,
                       vp.constData());
    glUniform3f(glGetUniformLocation(probeProgram_, "uEye"), eye.x(), eye.y(), eye.z());
    glUniform1f(glGetUniformLocation(probeProgram_, "uExposure"), exposure());
    // Impostors: one camera-facing quad per probe, the sphere ray cast in the fragment shader
    // (exact silhouette and depth; 4 vertices instead of hundreds, so 10k probes stay cheap).
    glDisable(GL_CULL_FACE);
    glUniformMatrix4fv(glGetUniformLocation(probeProgram_, "uViewProj"), 1, GL_FALSE,
                       vp.constData());
    glUniform1i(glGetUniformLocation(probeProgram_, "uImpostor"), 1);
    const QVector3D right = camera_.right(), up = camera_.up();
    glUniform3f(glGetUniformLocation(probeProgram_, "uRight"), right.x(), right.y(), right.z());
    glUniform3f(glGetUniformLocation(probeProgram_, "uUp"), up.x(), up.y(), up.z());
    const QVector3D forward = -camera_.backward();
    glUniform3f(glGetUniformLocation(probeProgram_, "uForward"), forward.x(), forward.y(),
                forward.z());
    glUniform1f(glGetUniformLocation(probeProgram_, "uMinRadiusScale"),
                kMinProbeRadiusPx * metresPerPixelPerMetre() / baseRadius_);
    glActiveTexture(GL_TEXTURE0);
    glBindTexture(GL_TEXTURE_BUFFER, instanceTex_);
    glUniform1i(glGetUniformLocation(probeProgram_, "uInstances"), 0);
    glBindVertexArray(impostorVao_);
    glUniform1i(glGetUniformLocation(probeProgram_, "uXray"), 0);
    glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, instanceCount_);
    // The x-ray ghosts help with a few hundred probes; with thousands they are clutter and cost a
    // second pass, so they are left out.
    if (instanceCount_ <= kMaxXrayProbes) {
      glDepthFunc(GL_GREATER);
      glDepthMask(GL_FALSE);
      glUniform1i(glGetUniformLocation(probeProgram_, "uXray"), 1);
      glDrawArraysInstanced(GL_TRIANGLE_STRIP, 0, 4, instanceCount_);
    }
    glUniform1i(glGetUniformLocation(probeProgram_, "uImpostor"), 0);
    glDepthFunc(GL_LESS);
    glDepthMask(GL_TRUE);
    glDisable(GL_BLEND);
  }
  drawOverlays(vp);
  drawSunGizmos(vp);
  drawHandle(vp);
  glBindVertexArray(0);
  glUseProgram(0);
  drawLegends();
}

void Viewport::drawHandle(const QMatrix4x4& vp) {
  const auto o = handleOrigin();
  if (!o || tool_ != Tool::Select) return;
  const float arm = handleArmMeters();
  const QVector3D axes[3] = {{1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  const QVector4D colors[3] = {
      {0.95f, 0.25f, 0.2f, 1}, {0.35f, 0.9f, 0.25f, 1}, {0.25f, 0.5f, 1.0f, 1}};
  const HandlePart active = drag_ == Drag::Handle ? dragPart_ : HandlePart::None;
  std::vector<float> lines, tris;
  auto put = [](std::vector<float>& v, QVector3D p, QVector4D c) {
    v.insert(v.end(), {p.x(), p.y(), p.z(), c.x(), c.y(), c.z(), c.w()});
  };
  const HandlePart arms[3] = {HandlePart::AxisX, HandlePart::AxisY, HandlePart::AxisZ};
  const HandlePart planes[3] = {HandlePart::PlaneYZ, HandlePart::PlaneXZ, HandlePart::PlaneXY};
  // The arms start at the surface of the selected probes' largest sphere (half the arm at
  // most), so that the handle, drawn over everything, leaves the probe it moves in sight.
  float gap = 0;
  for (quint64 id : selection_)
    if (const Probe* p = doc_->probe(id); p && isDrawn(*p)) gap = std::max(gap, drawnRadius(*p));
  gap = std::min(gap, 0.5f * arm);
  for (int i = 0; i < 3; ++i) {
    const QVector4D c = active == arms[i] ? QVector4D(1, 0.95f, 0.3f, 1) : colors[i];
    // The arm, drawn as a thin screen-facing quad so it reads at any line width.
    const QVector3D b = *o + axes[i] * gap, e = *o + axes[i] * arm;
    QVector3D side = QVector3D::crossProduct(axes[i], camera_.backward());
    if (side.lengthSquared() < 1e-8f) side = camera_.right();
    side = side.normalized() * arm * 0.015f;
    for (const QVector3D& p : {b - side, b + side, e + side, b - side, e + side, e - side})
      put(tris, p, c);
    // Arrow head.
    const QVector3D h = *o + axes[i] * arm * 0.82f;
    for (const QVector3D& p : {h - side * 4, e, h + side * 4}) put(tris, p, c);
    // Plane square between the other two axes, translucent.
    const QVector3D u = axes[(i + 1) % 3] * arm, v = axes[(i + 2) % 3] * arm;
    QVector4D pc = colors[i];
    pc.setW(active == planes[i] ? 0.75f : 0.35f);
    const QVector3D q0 = *o + u * 0.2f + v * 0.2f, q1 = *o + u * 0.45f + v * 0.2f,
                    q2 = *o + u * 0.45f + v * 0.45f, q3 = *o + u * 0.2f + v * 0.45f;
    for (const QVector3D& p : {q0, q1, q2, q0, q2, q3}) put(tris, p, pc);
    for (const QVector3D& p : {q0, q1, q1, q2, q2, q3, q3, q0}) put(lines, p, colors[i]);
  }
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glEnable(GL_BLEND);
  glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  glUseProgram(lineProgram_);
  glUniformMatrix4fv(glGetUniformLocation(lineProgram_, "uViewProj"), 1, GL_FALSE, vp.constData());
  glBindVertexArray(lineVao_);
  glBindBuffer(GL_ARRAY_BUFFER, lineVbo_);
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(tris.size() * sizeof(float)), tris.data(),
               GL_STREAM_DRAW);
  glDrawArrays(GL_TRIANGLES, 0, GLsizei(tris.size() / 7));
  glBufferData(GL_ARRAY_BUFFER, GLsizeiptr(lines.size() * sizeof(float)), lines.data(),
               GL_STREAM_DRAW);
  glDrawArrays(GL_LINES, 0, GLsizei(lines.size() / 7));
  glDisable(GL_BLEND);
  glEnable(GL_DEPTH_TEST);
}

// ---------------------------------------------------------------- the sun gizmo

std::vector<Viewport::SunGizmo> Viewport::sunGizmos() const {
  std::vector<SunGizmo> out;
  bool rigSun = false;
  for (const Light& l : doc_->probeSet().rig.lights)
    if (l.type == LightType::Directional && !rigSun && length(l.direction) > 0) {
      rigSun = true;
      out.push_back({sunDragTowards_ ? *sunDragTowards_ : -normalize(l.direction), true});
    }
  if (const Scene* scene = doc_->scene())
    for (const Light& l : scene->lights)
      if (l.type == LightType::Directional && length(l.direction) > 0)
        out.push_back({-normalize(l.direction), false});
  return out;
}

Vec3 Viewport::sunGizmoCentre() const {
  const Scene* scene = doc_->scene();
  return scene && !scene->bounds.empty() ? scene->bounds.center() : Vec3();
}

double Viewport::sunGizmoDistance() const {
  const Scene* scene = doc_->scene();
  return scene && !scene->bounds.empty() ? 0.5 * scene->bounds.diagonal() : 1.0;
}

std::optional<Vec3> Viewport::sunGizmoPosition() const {
  for (const SunGizmo& s : sunGizmos())
    if (s.editable) return sunGizmoCentre() + s.towardsSun * sunGizmoDistance();
  return std::nullopt;
}

Vec3 Viewport::sunSpherePoint(const PickRay& ray, Vec3 near) const {
  const Vec3 c = sunGizmoCentre();
  const double r = sunGizmoDistance();
  const Vec3 o(ray.origin.x(), ray.origin.y(), ray.origin.z());
  const Vec3 d = normalize(Vec3(ray.direction.x(), ray.direction.y(), ray.direction.z()));
  const Vec3 oc = o - c;
  const double b = dot(oc, d), disc = b * b - (dot(oc, oc) - r * r);
  if (disc < 0) {
    // The ray passes outside the sphere: its point nearest the centre, pushed out to the sphere
    // (the silhouette the cursor is beyond).
    const Vec3 q = o + d * std::max(-b, 0.0);
    return c + normalize(q - c) * r;
  }
  const double s = std::sqrt(disc);
  const Vec3 p0 = o + d * (-b - s), p1 = o + d * (-b + s);
  return length(p0 - near) <= length(p1 - near) ? p0 : p1;
}

void Viewport::drawSunGizmos(const QMatrix4x4& vp) {
  const std::vector<SunGizmo> suns = sunGizmos();
  if (suns.empty() || !doc_->hasScene()) return;
  std::vector<float> tris, lines;
  auto put = [](std::vector<float>& v, Vec3 p, QVector4D c) {
    v.insert(v.end(), {float(p.x), float(p.y), float(p.z), c.x(), c.y(), c.z(), c.w()});
  };
  const QVector3D right = camera_.right(), up = camera_.up();
  const Vec3 r(right.x(), right.y(), right.z()), u(up.x(), up.y(), up.z());
  const Vec3 centre = sunGizmoCentre();
  for (const SunGizmo& sun : suns) {
    const Vec3 at = centre + sun.towardsSun * sunGizmoDistance();
    const float depth =
        std::max(QVector3D::dotProduct(toQ(at) - camera_.eye(), -camera_.backward()), 1e-3f);
    const double px = double(depth * metresPerPixelPerMetre());  // metres per pixel there
    const bool active = sun.editable && drag_ == Drag::Sun;
    const QVector4D fill = !sun.editable ? QVector4D(0.85f, 0.65f, 0.3f, 0.55f)
                                         : (active ? QVector4D(1.0f, 0.97f, 0.6f, 1.0f)
                                                   : QVector4D(1.0f, 0.82f, 0.2f, 1.0f));
    const QVector4D stroke(fill.x() * 0.6f, fill.y() * 0.5f, fill.z() * 0.2f, fill.w());
    // The disc, facing the camera, kSunDiscPx in radius (editable) or 0.7 of it, with 8 rays.
    const double radius = px * kSunDiscPx * (sun.editable ? 1.0 : 0.7);
    constexpr int kSegments = 24;
    for (int i = 0; i < kSegments; ++i) {
      const double a0 = 2 * kPi * i / kSegments, a1 = 2 * kPi * (i + 1) / kSegments;
      put(tris, at, fill);
      put(tris, at + (r * std::cos(a0) + u * std::sin(a0)) * radius, fill);
      put(tris, at + (r * std::cos(a1) + u * std::sin(a1)) * radius, fill);
      put(lines, at + (r * std::cos(a0) + u * std::sin(a0)) * radius, stroke);
      put(lines, at + (r * std::cos(a1) + u * std::sin(a1)) * radius, stroke);
    }
    for (int i = 0; i < 8; ++i) {
      const double a = 2 * kPi * (i + 0.5) / 8;
      const Vec3 dir = r * std::cos(a) + u * std::sin(a);
      put(lines, at + dir * (radius * 1.3), fill);
      put(lines, at + dir * (radius * 1.75), fill);
    }
    // The light's path: from the disc towards the scene's centre, with an arrow head.
    const Vec3 tip = at - sun.towardsSun * (sunGizmoDistance() * 0.45);
    put(lines, at - sun.towardsSun * (radius * 1.3), fill);
    put(lines, tip, fill);
    Vec3 side = Vec3(0, 1, 0) - sun.towardsSun * sun.towardsSun.y;
    if (length(side) < 1e-6) side = r;
    side = normalize(side) * (px * 7);
    const Vec3 back = tip + sun.towardsSun * (px * 14);
    for (const Vec3& p : {back + side, tip, tip, back - side}) put(lines, p, fill);
  }
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_CULL_FACE);
  glEnable(GL_BLEND);
  glBlendFuncSeparate(GL_SRC_ALPHA, GL_ONE_MINUS_SRC_ALPHA, GL_ONE, GL_ONE_MINUS_SRC_ALPHA);
  drawLines(tris, GL_TRIANGLES, vp);
  drawLines(lines, GL_LINES, vp);
  glDisable(GL_BLEND);
  glEnable(GL_DEPTH_TEST);
}

}  // namespace ps::ui
