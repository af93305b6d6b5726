// check_screenshot SHOT.png NOPROBES.png: checks an editor screenshot against its JSON sidecar
// (SHOT.png.json, written by probestudio-editor --screenshot) and a render of the same view with
// the probes hidden. Thresholds (8-bit sRGB):
//   - the image is not uniform (standard deviation of luminance > 10);
//   - the scene covers >= 20% of the frame (pixels of the probe-less render that differ from the
//     background gradient by more than 12 in some channel);
//   - >= 75% of on-screen probes are drawn where the JSON says: the mean absolute difference
//     between the two renders over a small square at the projected centre exceeds 12;
//   - at least 10 probes are on screen;
//   - probes are shaded by their own SH: over the drawn probes, the Spearman rank correlation
//     between the luma at the centre of the sphere and the probe's mean radiance (sidecar) is
//     at least 0.6.
//
// check_screenshot --overlays SHOT.png BASE.png: SHOT shows overlays (written with --overlays
// glyphs,slice,...), BASE the same view without them. Thresholds:
//   - glyphs: at least 60 % of the on-screen glyph centres in the sidecar have a pixel within
//     3 px that differs from BASE by more than 40 in some channel (an arrow is drawn there);
//   - slice: at least 50 % of a 5 x 5 grid of points inside the projected slice quad differ
//     from BASE by more than 12 (the slice is drawn where its corners project);
//   - nothing outside the scene: over the pixels where BASE shows the background gradient (but
//     for the legends' rectangles, sidecar "legends"), the
//     mean absolute difference is below 1.5 (overlays stay inside the scene).
//
// check_screenshot --volumes SHOT.png BASE.png: SHOT shows importance volumes, BASE the same view
// without. Of the points at 1/8 ... 7/8 along each on-screen box edge (from the sidecar), at
// least 60 % have a pixel within 2 px that differs from BASE by more than 20 and has the box's
// hue: orange (red above blue by 25) for a weight >= 1, blue (blue above red by 25) below 1.
//
// check_screenshot --min-radius PX SHOT.png NOPROBES.png: the probes are drawn at least PX
// pixels in radius (accepted; 0.7 PX for the others, the viewport's factors), however far the
// view. Every on-screen probe's sidecar radiusPx is at least that, and of the probes drawn at
// their centre (as above), at least 80 % differ from NOPROBES by more than 12 at both pixels
// 0.8 of that radius left and right of the centre.
#include <QFile>
#include <QImage>
#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <QRectF>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <utility>
#include <vector>

namespace {
int fail(const char* what) {
  std::fprintf(stderr, "check_screenshot: FAIL: %s\n", what);
  return 1;
}
int channelDiff(QRgb a, QRgb b) {
  return std::max({std::abs(qRed(a) - qRed(b)), std::abs(qGreen(a) - qGreen(b)),
                   std::abs(qBlue(a) - qBlue(b))});
}
/// A render, the same view without what it checks, and the render's sidecar; "" when all read.
struct Pair {
  QImage shot, base;
  QJsonObject root;
};
const char* loadPair(const char* shotPath, const char* basePath, Pair& p) {
  p.shot = QImage(shotPath).convertToFormat(QImage::Format_RGB32);
  p.base = QImage(basePath).convertToFormat(QImage::Format_RGB32);
  if (p.shot.isNull() || p.base.isNull()) return "cannot read the images";
  if (p.shot.size() != p.base.size()) return "the two renders differ in size";
  QFile jf(QString::fromLocal8Bit(shotPath) + ".json");
  if (!jf.open(QIODevice::ReadOnly)) return "cannot read SHOT.png.json";
  p.root = QJsonDocument::fromJson(jf.readAll()).object();
  return "";
}
}  // namespace

int checkOverlays(const char* shotPath, const char* basePath) {
  Pair pair;
  if (const char* why = loadPair(shotPath, basePath, pair); *why) return fail(why);
  const QImage &shot = pair.shot, &base = pair.base;
  const QJsonObject& root = pair.root;
  const int w = shot.width(), h = shot.height();
  auto diffAt = [&](int x, int y) {
    if (x < 0 || y < 0 || x >= w || y >= h) return -1;
    return channelDiff(shot.pixel(x, y), base.pixel(x, y));
  };

  const QJsonArray glyphs = root["glyphs"].toArray();
  int glyphsOn = 0, glyphsDrawn = 0;
  for (const QJsonValue& g : glyphs) {
    const QJsonArray c = g.toObject()["centre"].toArray();
    if (c.size() != 2) continue;
    const int cx = int(c[0].toDouble()), cy = int(c[1].toDouble());
    if (cx < 3 || cy < 3 || cx >= w - 3 || cy >= h - 3) continue;
    ++glyphsOn;
    int best = 0;
    for (int y = cy - 3; y <= cy + 3; ++y)
      for (int x = cx - 3; x <= cx + 3; ++x) best = std::max(best, diffAt(x, y));
    if (best > 40) ++glyphsDrawn;
  }
  std::printf("glyphs on screen %d, drawn at their centre %d\n", glyphsOn, glyphsDrawn);
  if (glyphsOn < 50) return fail("fewer than 50 glyphs on screen");
  if (glyphsDrawn < 0.6 * glyphsOn) return fail("fewer than 60% of the glyphs are drawn");

  const QJsonArray corners = root["slice"].toObject()["corners"].toArray();
  if (corners.size() != 4) return fail("no slice in the sidecar");
  QPointF q[4];
  for (int i = 0; i < 4; ++i) {
    const QJsonArray c = corners[i].toArray();
    if (c.size() != 2) return fail("a slice corner is behind the camera");
    q[i] = QPointF(c[0].toDouble(), c[1].toDouble());
  }
  int sliceDrawn = 0, sliceOn = 0;
  for (int i = 0; i < 5; ++i)
    for (int j = 0; j < 5; ++j) {
      const double u = 0.15 + 0.7 * i / 4.0, v = 0.15 + 0.7 * j / 4.0;
      const QPointF p = q[0] * (1 - u) * (1 - v) + q[1] * u * (1 - v) + q[2] * u * v +
                        q[3] * (1 - u) * v;  // bilinear inside the projected quad
      const int d = diffAt(int(p.x()), int(p.y()));
      if (d < 0) continue;
      ++sliceOn;
      if (d > 12) ++sliceDrawn;
    }
  std::printf("slice points on screen %d, drawn %d\n", sliceOn, sliceDrawn);
  if (sliceOn < 10) return fail("the slice is mostly off screen");
  // Two-rooms, the slice at y = 0.99 m: measured 17-18 of 25 (0.68-0.72) at viewport sizes
  // 640x480 ... 1280x960. In both renders 7 points are hidden at every size (5 behind the south
  // wall, 2 under probes) and 0-1 under the selected probe's gizmo. At least 0.5: 13 of 25, 4
  // points below the lowest measured.
  if (sliceDrawn < 0.5 * sliceOn) return fail("the slice is not drawn where it projects");

  const QJsonObject bg = root["background"].toObject();
  const QJsonArray top = bg["top"].toArray(), bottom = bg["bottom"].toArray();
  // The legends are drawn over the background on purpose.
  std::vector<QRectF> legends;
  for (const QJsonValue& r : root["legends"].toArray()) {
    const QJsonArray a = r.toArray();
    legends.emplace_back(a[0].toDouble(), a[1].toDouble(), a[2].toDouble(), a[3].toDouble());
  }
  auto inLegend = [&](int x, int y) {
    for (const QRectF& r : legends)
      if (r.adjusted(-1, -1, 1, 1).contains(x, y)) return true;
    return false;
  };
  double outside = 0;
  long outsideCount = 0;
  for (int y = 0; y < h; ++y) {
    const double t = h > 1 ? double(y) / (h - 1) : 0;
    auto mix = [&](int c) {
      return int(std::lround(top[c].toInt() * (1 - t) + bottom[c].toInt() * t));
    };
    const QRgb expected = qRgb(mix(0), mix(1), mix(2));
    for (int x = 0; x < w; ++x)
      if (channelDiff(base.pixel(x, y), expected) <= 3 && !inLegend(x, y)) {
        outside += diffAt(x, y);
        ++outsideCount;
      }
  }
  const double outsideMean = outsideCount ? outside / double(outsideCount) : 0.0;
  std::printf("background pixels %ld, mean change %.2f\n", outsideCount, outsideMean);
  if (outsideCount < 1000) return fail("too little background to check");
  if (outsideMean >= 1.5) return fail("overlays drawn outside the scene");
  std::printf("check_screenshot --overlays: OK\n");
  return 0;
}

int checkVolumes(const char* shotPath, const char* basePath) {
  Pair pair;
  if (const char* why = loadPair(shotPath, basePath, pair); *why) return fail(why);
  const QImage &shot = pair.shot, &base = pair.base;
  const QJsonArray volumes = pair.root["importanceVolumes"].toArray();
  if (volumes.isEmpty()) return fail("no importance volumes in the sidecar");
  const int w = shot.width(), h = shot.height();
  for (int vi = 0; vi < volumes.size(); ++vi) {
    const QJsonObject v = volumes[vi].toObject();
    const bool warm = v["weight"].toDouble() >= 1;
    int on = 0, drawn = 0;
    for (const QJsonValue& e : v["edges"].toArray()) {
      const QJsonArray a = e.toArray()[0].toArray(), b = e.toArray()[1].toArray();
      if (a.size() != 2 || b.size() != 2) continue;
      for (int k = 1; k < 8; ++k) {
        const double t = k / 8.0;
        const int cx = int(a[0].toDouble() * (1 - t) + b[0].toDouble() * t);
        const int cy = int(a[1].toDouble() * (1 - t) + b[1].toDouble() * t);
        if (cx < 2 || cy < 2 || cx >= w - 2 || cy >= h - 2) continue;
        ++on;
        bool found = false;
        for (int y = cy - 2; y <= cy + 2 && !found; ++y)
          for (int x = cx - 2; x <= cx + 2 && !found; ++x) {
            const QRgb p = shot.pixel(x, y);
            const int hue = warm ? qRed(p) - qBlue(p) : qBlue(p) - qRed(p);
            found = hue > 25 && channelDiff(p, base.pixel(x, y)) > 20;
          }
        drawn += found;
      }
    }
    std::printf("importance volume %d (%s): edge points on screen %d, drawn %d\n", vi + 1,
                warm ? "orange" : "blue", on, drawn);
    if (on < 20) return fail("an importance volume is mostly off screen");
    if (drawn < 0.6 * on) return fail("an importance volume is not drawn where its edges project");
  }
  std::printf("check_screenshot --volumes: OK\n");
  return 0;
}

/// --domain: SHOT shows the domain of interest's shell (faint green lines, ui/DomainOverlay.cpp)
/// over BASE, the same view without it: at least 2000 pixels turned greener than BASE (green
/// up by more than 12 and more than red and blue).
int checkDomain(const char* shotPath, const char* basePath) {
  Pair pair;
  if (const char* why = loadPair(shotPath, basePath, pair); *why) return fail(why);
  int greener = 0;
  for (int y = 0; y < pair.shot.height(); ++y)
    for (int x = 0; x < pair.shot.width(); ++x) {
      const QRgb s = pair.shot.pixel(x, y), b = pair.base.pixel(x, y);
      const int dg = qGreen(s) - qGreen(b), dr = qRed(s) - qRed(b), db = qBlue(s) - qBlue(b);
      greener += dg > 12 && dg > dr && dg > db;
    }
  std::printf("pixels greener than the base: %d\n", greener);
  if (greener < 2000) return fail("the domain's shell is not drawn");
  std::printf("check_screenshot --domain: OK\n");
  return 0;
}

int checkMinRadius(double minPx, const char* shotPath, const char* basePath) {
  Pair pair;
  if (const char* why = loadPair(shotPath, basePath, pair); *why) return fail(why);
  const QImage &shot = pair.shot, &bare = pair.base;
  const int w = shot.width(), h = shot.height();
  auto differs = [&](int x, int y) {
    return x >= 0 && y >= 0 && x < w && y < h &&
           channelDiff(shot.pixel(x, y), bare.pixel(x, y)) > 12;
  };
  int onScreen = 0, drawn = 0, wide = 0;
  double smallest = 1e9;
  for (const QJsonValue& v : pair.root["probes"].toArray()) {
    const QJsonObject p = v.toObject();
    if (!p["onScreen"].toBool()) continue;
    ++onScreen;
    const double least = minPx * (p["state"].toString() == QLatin1String("accepted") ? 1.0 : 0.7);
    const double radius = p["radiusPx"].toDouble();
    smallest = std::min(smallest, radius / least);
    const int cx = int(std::lround(p["x"].toDouble())), cy = int(std::lround(p["y"].toDouble()));
    if (!differs(cx, cy)) continue;  // hidden (behind another probe's ghost or a wall)
    ++drawn;
    const int d = int(0.8 * least);
    if (differs(cx - d, cy) && differs(cx + d, cy)) ++wide;
  }
  std::printf(
      "probes on screen %d, drawn %d, of them as wide as the minimum %d; sidecar radius / "
      "minimum >= %.2f\n",
      onScreen, drawn, wide, smallest);
  if (onScreen < 10) return fail("fewer than 10 probes on screen");
  if (smallest < 0.99) return fail("a probe's sidecar radius is below the minimum");
  if (wide < 0.8 * drawn)
    return fail("fewer than 80% of the drawn probes are as wide as the minimum");
  std::printf("check_screenshot: OK\n");
  return 0;
}

int main(int argc, char** argv) {
  if (argc == 5 && QString::fromLatin1(argv[1]) == QLatin1String("--min-radius"))
    return checkMinRadius(QString::fromLatin1(argv[2]).toDouble(), argv[3], argv[4]);
  if (argc == 4 && QString::fromLatin1(argv[1]) == QLatin1String("--overlays"))
    return checkOverlays(argv[2], argv[3]);
  if (argc == 4 && QString::fromLatin1(argv[1]) == QLatin1String("--volumes"))
    return checkVolumes(argv[2], argv[3]);
  if (argc == 4 && QString::fromLatin1(argv[1]) == QLatin1String("--domain"))
    return checkDomain(argv[2], argv[3]);
  if (argc != 3)
    return fail(
        "usage: check_screenshot SHOT.png NOPROBES.png | --overlays SHOT.png BASE.png | "
        "--volumes SHOT.png BASE.png | --domain SHOT.png BASE.png");
  const QImage shot = QImage(argv[1]).convertToFormat(QImage::Format_RGB32);
  const QImage bare = QImage(argv[2]).convertToFormat(QImage::Format_RGB32);
  if (shot.isNull() || bare.isNull()) return fail("cannot read the images");
  if (shot.size() != bare.size()) return fail("the two renders differ in size");
  QFile jf(QString::fromLocal8Bit(argv[1]) + ".json");
  if (!jf.open(QIODevice::ReadOnly)) return fail("cannot read SHOT.png.json");
  const QJsonObject root = QJsonDocument::fromJson(jf.readAll()).object();
  const int w = shot.width(), h = shot.height();
  if (root["image"].toObject()["width"].toInt() != w) return fail("json size mismatch");

  // 1. Not uniform.
  double sum = 0, sum2 = 0;
  for (int y = 0; y < h; ++y)
    for (int x = 0; x < w; ++x) {
      const double l = qGray(shot.pixel(x, y));
      sum += l;
      sum2 += l * l;
    }
  const double n = double(w) * h, mean = sum / n;
  const double stddev = std::sqrt(std::max(0.0, sum2 / n - mean * mean));
  std::printf("luminance mean %.1f, stddev %.1f\n", mean, stddev);
  if (stddev <= 10) return fail("the image is (nearly) uniform");

  // 2. Scene coverage against the background gradient (top colour at row 0, bottom at row h-1).
  const QJsonObject bg = root["background"].toObject();
  const QJsonArray top = bg["top"].toArray(), bottom = bg["bottom"].toArray();
  long covered = 0;
  for (int y = 0; y < h; ++y) {
    const double t = h > 1 ? double(y) / (h - 1) : 0;
    auto mix = [&](int c) {
      return int(std::lround(top[c].toInt() * (1 - t) + bottom[c].toInt() * t));
    };
    const QRgb expected = qRgb(mix(0), mix(1), mix(2));
    for (int x = 0; x < w; ++x)
      if (channelDiff(bare.pixel(x, y), expected) > 12) ++covered;
  }
  const double coverage = covered / n;
  std::printf("scene coverage %.1f%%\n", 100 * coverage);
  if (coverage < 0.20) return fail("the scene covers less than 20% of the frame");

  // 3. Probes drawn at their projected positions.
  int onScreen = 0, shown = 0;
  for (const QJsonValue& v : root["probes"].toArray()) {
    const QJsonObject p = v.toObject();
    if (!p["onScreen"].toBool()) continue;
    ++onScreen;
    const int cx = int(p["x"].toDouble()), cy = int(p["y"].toDouble());
    const int half = std::clamp(int(p["radiusPx"].toDouble() * 0.5), 1, 6);
    double diff = 0;
    int count = 0;
    for (int y = std::max(0, cy - half); y <= std::min(h - 1, cy + half); ++y)
      for (int x = std::max(0, cx - half); x <= std::min(w - 1, cx + half); ++x) {
        diff += channelDiff(shot.pixel(x, y), bare.pixel(x, y));
        ++count;
      }
    if (count > 0 && diff / count > 12) ++shown;
  }
  std::printf("probes on screen %d, drawn at their projected position %d\n", onScreen, shown);
  if (onScreen < 10) return fail("fewer than 10 probes on screen");
  // Two-rooms: measured 53-54 of 63 (0.84-0.86) at viewport sizes 640x480 ... 1280x960. Not
  // drawn at every size: the 7 probes behind the south wall (x-ray ghosts, mean difference 3-13;
  // the one at 12 decides 53 or 54) and 3 pale probes in front of room A's pale north wall (5-9).
  // At least 0.75: 48 of 63, 5 probes below the lowest measured.
  if (shown < 0.75 * onScreen) return fail("fewer than 75% of on-screen probes are drawn");

  // 4. Shaded by their own SH: brighter probes (mean radiance) look brighter.
  std::vector<std::pair<double, double>> pairs;  // mean radiance, centre luma
  for (const QJsonValue& v : root["probes"].toArray()) {
    const QJsonObject p = v.toObject();
    if (!p["onScreen"].toBool() || !p.contains("meanRadiance")) continue;
    const int cx = int(p["x"].toDouble()), cy = int(p["y"].toDouble());
    if (cx < 1 || cy < 1 || cx >= w - 1 || cy >= h - 1) continue;
    if (channelDiff(shot.pixel(cx, cy), bare.pixel(cx, cy)) <= 12) continue;  // hidden
    double luma = 0;
    for (int y = cy - 1; y <= cy + 1; ++y)
      for (int x = cx - 1; x <= cx + 1; ++x) luma += qGray(shot.pixel(x, y)) / 9.0;
    pairs.emplace_back(p["meanRadiance"].toDouble(), luma);
  }
  auto ranks = [&](bool second) {
    std::vector<size_t> order(pairs.size());
    for (size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](size_t a, size_t b) {
      return second ? pairs[a].second < pairs[b].second : pairs[a].first < pairs[b].first;
    });
    std::vector<double> r(pairs.size());
    for (size_t i = 0; i < order.size(); ++i) r[order[i]] = double(i);
    return r;
  };
  if (pairs.size() < 10) return fail("fewer than 10 captured probes drawn");
  const std::vector<double> ra = ranks(false), rb = ranks(true);
  double d2 = 0;
  for (size_t i = 0; i < pairs.size(); ++i) d2 += (ra[i] - rb[i]) * (ra[i] - rb[i]);
  const double m = double(pairs.size());
  const double rho = 1.0 - 6.0 * d2 / (m * (m * m - 1.0));
  std::printf("probe luma vs mean radiance: Spearman %.2f over %zu probes\n", rho, pairs.size());
  if (rho < 0.6) return fail("probe shading does not follow their SH");
  std::printf("check_screenshot: OK\n");
  return 0;
}
