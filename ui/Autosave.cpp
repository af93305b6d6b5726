#include "ui/Autosave.h"

#include <QDir>
#include <QFile>
#include <QFileInfo>
#include <QJsonDocument>
#include <QJsonObject>
#include <QLockFile>
#include <QSaveFile>
#include <QTimer>
#include <QUuid>
#include <algorithm>

#include "core/common/Error.h"
#include "ui/Document.h"

namespace ps::ui {

namespace {
constexpr const char* kProbesSuffix = ".probes.json";
constexpr const char* kMetaSuffix = ".meta.json";
constexpr const char* kLockSuffix = ".lock";
}  // namespace

Autosave::Autosave(Document* doc, const QString& folder, int intervalMs, QObject* parent)
    : QObject(parent),
      doc_(doc),
      folder_(folder),
      id_(QUuid::createUuid().toString(QUuid::WithoutBraces)),
      timer_(new QTimer(this)) {
  QDir().mkpath(folder_);
  lock_ = std::make_unique<QLockFile>(base() + kLockSuffix);
  lock_->setStaleLockTime(0);  // never time out while this process lives
  if (!lock_->tryLock(100)) lastError_ = tr("cannot lock %1").arg(lock_->error());
  timer_->setInterval(intervalMs);
  connect(timer_, &QTimer::timeout, this, [this] { saveNow(); });
  timer_->start();
  // Saved, reverted or replaced: nothing to recover any more.
  connect(doc_, &Document::modifiedChanged, this, [this](bool modified) {
    if (!modified && !abandoned_) removeFiles();
  });
}

Autosave::~Autosave() {
  if (!abandoned_) removeFiles();
}

QString Autosave::base() const {
  return QDir(folder_).filePath(QStringLiteral("session-") + id_);
}

QString Autosave::recoveryPath() const {
  return base() + kProbesSuffix;
}

void Autosave::removeFiles() {
  if (abandoned_) return;
  QFile::remove(base() + kProbesSuffix);
  QFile::remove(base() + kMetaSuffix);
  savedChange_ = ~quint64(0);
}

bool Autosave::saveNow() {
  if (abandoned_) return QFile::exists(recoveryPath());
  if (!doc_->isModified() || !doc_->hasScene()) {
    removeFiles();
    return false;
  }
  if (savedChange_ == doc_->changeCount() && QFile::exists(recoveryPath())) return true;
  try {
    doc_->writeCopy(recoveryPath());  // atomic: a crash mid-write keeps the previous copy
  } catch (const Error& e) {
    lastError_ = QString::fromStdString(e.what());
    return QFile::exists(recoveryPath());
  }
  QJsonObject meta{{"originalSetPath", doc_->probeSetPath()},
                   {"scenePath", doc_->scenePath()},
                   {"savedAt", QDateTime::currentDateTimeUtc().toString(Qt::ISODate)}};
  QSaveFile f(base() + kMetaSuffix);
  if (!f.open(QIODevice::WriteOnly) || f.write(QJsonDocument(meta).toJson()) < 0 || !f.commit())
    lastError_ = tr("%1: cannot write").arg(f.fileName());
  savedChange_ = doc_->changeCount();
  return true;
}

void Autosave::abandon() {
  abandoned_ = true;
  timer_->stop();
  lock_->unlock();
}

std::vector<Autosave::Orphan> Autosave::findOrphans(const QString& folder) {
  std::vector<Orphan> out;
  const QDir dir(folder);
  const QStringList files =
      dir.entryList({QStringLiteral("session-*") + kProbesSuffix}, QDir::Files);
  for (const QString& name : files) {
    const QString stem = dir.filePath(name.left(name.size() - int(qstrlen(kProbesSuffix))));
    {
      // A lock we can take belongs to no running session (QLockFile removes a stale lock whose
      // process is gone).
      QLockFile lock(stem + kLockSuffix);
      lock.setStaleLockTime(0);  // stale only when its process is gone, however old
      if (!lock.tryLock(0)) continue;
    }  // unlocks and removes the lock file
    Orphan o;
    o.recoveryPath = stem + kProbesSuffix;
    QFile meta(stem + kMetaSuffix);
    if (meta.open(QIODevice::ReadOnly)) {
      const QJsonObject m = QJsonDocument::fromJson(meta.readAll()).object();
      o.originalSetPath = m["originalSetPath"].toString();
      o.scenePath = m["scenePath"].toString();
      o.savedAt = QDateTime::fromString(m["savedAt"].toString(), Qt::ISODate);
    }
    if (!o.savedAt.isValid()) o.savedAt = QFileInfo(o.recoveryPath).lastModified();
    out.push_back(o);
  }
  std::sort(out.begin(), out.end(),
            [](const Orphan& a, const Orphan& b) { return a.savedAt > b.savedAt; });
  return out;
}

void Autosave::discard(const Orphan& orphan) {
  QString stem = orphan.recoveryPath;
  stem.chop(int(qstrlen(kProbesSuffix)));
  QFile::remove(stem + kProbesSuffix);
  QFile::remove(stem + kMetaSuffix);
  QFile::remove(stem + kLockSuffix);
}

}  // namespace ps::ui
