// The editor's layout at 1280 x 800 (run under xvfb-run, as ui.test_layout does): every label,
// button, tab and plot axis shows its whole text, before and after a placement that leaves
// its notes in the placement panel, and with the longest job message in the status bar.
#include <QAbstractButton>
#include <QApplication>
#include <QChart>
#include <QChartView>
#include <QDir>
#include <QDockWidget>
#include <QFile>
#include <QLabel>
#include <QLegend>
#include <QLegendMarker>
#include <QSignalSpy>
#include <QSpinBox>
#include <QStatusBar>
#include <QStyle>
#include <QTabBar>
#include <QValueAxis>
#include <QtTest>

#include "ui/Document.h"
#include "ui/EvaluationPanel.h"
#include "ui/MainWindow.h"
#include "ui/PlacementPanel.h"

using namespace ps;
using namespace ps::ui;

namespace {
const QString kScene = QStringLiteral(PS_SOURCE_DIR "/resources/scenes/two-rooms.gltf");

/// The texts of the window's visible labels, buttons and tabs that do not fit where they are
/// drawn, one line each naming the widget; the plot axes that may cut their labels.
QStringList cutTexts(QMainWindow& w) {
  QStringList out;
  auto name = [](const QWidget* x) {
    return QStringLiteral("%1 %2").arg(x->metaObject()->className(), x->objectName());
  };
  for (QLabel* l : w.findChildren<QLabel*>()) {
    if (!l->isVisibleTo(&w) || l->text().isEmpty() || l->textFormat() == Qt::RichText ||
        !l->pixmap().isNull())
      continue;
    const QRect r = l->contentsRect();
    if (l->wordWrap()) {
      if (l->heightForWidth(r.width()) > r.height() + 1)
        out << QStringLiteral("%1 '%2': wrapped to %3 px high in %4")
                   .arg(name(l), l->text())
                   .arg(l->heightForWidth(r.width()))
                   .arg(r.height());
    } else {
      const QSize need = l->fontMetrics().size(0, l->text());
      if (need.width() > r.width() + 1 || need.height() > r.height() + 1)
        out << QStringLiteral("%1 '%2': needs %3 x %4, has %5 x %6")
                   .arg(name(l), l->text())
                   .arg(need.width())
                   .arg(need.height())
                   .arg(r.width())
                   .arg(r.height());
    }
  }
  for (QAbstractButton* b : w.findChildren<QAbstractButton*>()) {
    if (!b->isVisibleTo(&w) || b->text().isEmpty()) continue;
    if (b->sizeHint().width() > b->width() + 1)
      out << QStringLiteral("%1 '%2': needs %3 px, has %4")
                 .arg(name(b), b->text())
                 .arg(b->sizeHint().width())
                 .arg(b->width());
  }
  for (QTabBar* bar : w.findChildren<QTabBar*>()) {
    if (!bar->isVisibleTo(&w)) continue;
    for (int i = 0; i < bar->count(); ++i) {
      // As QTabBar::tabSizeHint measures a tab: its text and the style's padding.
      const QString text = bar->tabText(i);
      const int need = bar->fontMetrics().size(Qt::TextShowMnemonic, text).width() +
                       bar->style()->pixelMetric(QStyle::PM_TabBarTabHSpace, nullptr, bar);
      if (need > bar->tabRect(i).width())
        out << QStringLiteral("tab '%1': needs %2 px, has %3")
                   .arg(text)
                   .arg(need)
                   .arg(bar->tabRect(i).width());
    }
  }
  for (QChartView* view : w.findChildren<QChartView*>()) {
    if (!view->isVisibleTo(&w)) continue;
    QChart* chart = view->chart();
    for (QAbstractAxis* axis : chart->axes()) {
      if (axis->truncateLabels())
        out << QStringLiteral("axis '%1' truncates").arg(axis->titleText());
      // A vertical axis' title runs along the plot's height.
      const int need = QFontMetrics(axis->titleFont()).horizontalAdvance(axis->titleText());
      if (axis->orientation() == Qt::Vertical && need > chart->plotArea().height())
        out << QStringLiteral("axis title '%1': needs %2 px, has %3")
                   .arg(axis->titleText())
                   .arg(need)
                   .arg(chart->plotArea().height());
    }
    // The legend's names side by side, each after its marker (QLegend cuts a name that does
    // not fit): its width must hold them, with a margin per marker.
    constexpr int kMarkerPx = 30;
    int need = 0;
    for (QLegendMarker* m : chart->legend()->markers())
      if (m->isVisible()) need += QFontMetrics(m->font()).horizontalAdvance(m->label()) + kMarkerPx;
    if (need > chart->legend()->geometry().width())
      out << QStringLiteral("plot legend: needs %1 px, has %2")
                 .arg(need)
                 .arg(chart->legend()->geometry().width());
  }
  return out;
}

/// Shows every dock's tab in turn (a tabbed dock lays out only when shown), checking each.
QStringList cutTextsInEveryTab(QMainWindow& w) {
  QStringList out;
  for (QDockWidget* d : w.findChildren<QDockWidget*>()) {
    d->raise();
    QApplication::processEvents();
    out << cutTexts(w);
  }
  out.removeDuplicates();
  return out;
}
}  // namespace

class TestLayout : public QObject {
  Q_OBJECT

 private slots:
  void initTestCase() {
    if (!QFile::exists(kScene)) QSKIP("two-rooms.gltf not present");
  }

  void nothingIsCutAt1280x800() {
    if (QGuiApplication::platformName() == QLatin1String("offscreen"))
      QSKIP("needs OpenGL: run under xvfb-run (ui.test_layout)");
    MainWindow w;
    w.setQuiet(true);
    w.setPromptOnClose(false);
    Document* doc = w.document();
    doc->setAutoPropose(false);
    w.resize(1280, 800);
    w.show();
    QVERIFY(QTest::qWaitForWindowExposed(&w));
    QVERIFY(w.openPath(kScene));
    QCOMPARE(w.size(), QSize(1280, 800));
    QStringList cut = cutTextsInEveryTab(w);
    QVERIFY2(cut.isEmpty(), qPrintable(cut.join('\n')));

    // A greedy placement leaves its notes in the placement panel; the form keeps its height.
    w.findChild<QDockWidget*>("placementDock")->raise();
    PlacementPanel* panel = w.placementPanel();
    panel->budgetBox()->setValue(16);
    QVERIFY(panel->run());
    QSignalSpy done(doc, &Document::jobFinished);
    // The status bar's job text at its longest, while the job runs.
    QTRY_VERIFY_WITH_TIMEOUT(doc->isBusy() && !w.findChild<QLabel*>("jobLabel")->text().isEmpty(),
                             10000);
    cut = cutTexts(w);
    QVERIFY2(cut.isEmpty(), qPrintable(cut.join('\n')));
    QVERIFY(done.wait(300000));
    QCOMPARE(done.first().first().toString(), QString());
    QApplication::processEvents();
    cut = cutTextsInEveryTab(w);
    QVERIFY2(cut.isEmpty(), qPrintable(cut.join('\n')));
    const QByteArray artifacts = qgetenv("PS_ARTIFACTS");
    if (!artifacts.isEmpty()) {
      QDir().mkpath(QString::fromLocal8Bit(artifacts));
      for (const char* dock : {"placementDock", "lightingDock", "evaluationDock"}) {
        w.findChild<QDockWidget*>(dock)->raise();
        QApplication::processEvents();
        w.grab().save(QString::fromLocal8Bit(artifacts) + "/editor-1280x800-" + dock + ".png");
      }
    }
  }
};

QTEST_MAIN(TestLayout)
#include "test_layout.moc"
