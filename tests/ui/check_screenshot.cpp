// check_screenshot SHOT.png NOPROBES.png: checks an editor screenshot against its JSON sidecar
// (SHOT.png.json, written by probestudio-editor --screenshot) and a render of the same view with
// the probes hidden. Thresholds (8-bit sRGB):
//   - the image is not uniform (standard deviation of luminance > 10);
//   - the scene covers >= 20% of the frame (pixels of the probe-less render that differ from the
//     background gradient by more than 12 in some channel);
//   - >= 80% of on-screen probes are drawn where the JSON says: the mean absolute difference
//     between the two renders over a small square at the projected centre exceeds 12;
//   - at least 10 probes are on screen.
#include <QFile>
#include <QImage>
#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <algorithm>
#include <cmath>
#include <cstdio>

namespace {
int fail(const char* what) {
  std::fprintf(stderr, "check_screenshot: FAIL: %s\n", what);
  return 1;
}
int channelDiff(QRgb a, QRgb b) {
  return std::max({std::abs(qRed(a) - qRed(b)), std::abs(qGreen(a) - qGreen(b)),
                   std::abs(qBlue(a) - qBlue(b))});
}
}  // namespace

int main(int argc, char** argv) {
  if (argc != 3) return fail("usage: check_screenshot SHOT.png NOPROBES.png");
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
  if (shown < 0.8 * onScreen) return fail("fewer than 80% of on-screen probes are drawn");
  std::printf("check_screenshot: OK\n");
  return 0;
}
