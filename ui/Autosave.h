#pragma once
// Autosave to a recovery file, offered at the next start after a crash.
// Each editor session owns three files in the recovery folder, named after a random session id:
//   session-ID.lock         a QLockFile held while the session runs
//   session-ID.probes.json  the probe set as the user last had it (core probe-set format)
//   session-ID.meta.json    {"originalSetPath", "scenePath", "savedAt"}
// The set is written every interval when the document has unsaved changes that differ from the
// last autosave, and removed when the document becomes clean (saved, reverted, replaced) and
// when the session ends normally. A probes file whose lock nobody holds is therefore the work of
// a session that crashed: an orphan, which the next session offers to recover.
#include <QDateTime>
#include <QObject>
#include <QString>
#include <memory>
#include <vector>

class QLockFile;
class QTimer;

namespace ps::ui {

class Document;

class Autosave : public QObject {
  Q_OBJECT
 public:
  /// Starts a session in `folder` (created when missing). Autosaves every `intervalMs`.
  Autosave(Document* doc, const QString& folder, int intervalMs = 30000, QObject* parent = nullptr);
  /// A normal end: removes this session's files.
  ~Autosave() override;

  /// Writes the recovery copy now when the document has changes not yet autosaved; removes it
  /// when the document is clean. Returns true when a recovery copy exists afterwards. A failed
  /// write (full disk, ...) is reported through lastError() and never thrown.
  bool saveNow();
  QString recoveryPath() const;
  QString lastError() const { return lastError_; }

  struct Orphan {
    QString recoveryPath;     ///< the probes file to pass to Document::recover
    QString originalSetPath;  ///< the file the user was editing (empty: never saved)
    QString scenePath;
    QDateTime savedAt;
  };
  /// Recovery files in `folder` left by sessions that are no longer running, newest first.
  static std::vector<Orphan> findOrphans(const QString& folder);
  /// Deletes an orphan's files.
  static void discard(const Orphan& orphan);

  /// What a crash leaves behind: releases the session lock but keeps the recovery files, and
  /// stops autosaving. For tests of the recovery path.
  void abandon();

 private:
  void removeFiles();
  QString base() const;

  Document* doc_;
  QString folder_, id_;
  QTimer* timer_;
  std::unique_ptr<QLockFile> lock_;
  quint64 savedChange_ = ~quint64(0);
  bool abandoned_ = false;
  QString lastError_;
};

}  // namespace ps::ui
