// mrsns: the MR-SNS workstation. Without arguments it opens (a working copy
// of) the bundled sample session; `mrsns SESSION_DIR` opens that session;
// `--screenshot PNG` renders the window to a PNG and exits (docs, tests).
#include <QApplication>
#include <QCommandLineParser>
#include <QElapsedTimer>
#include <QTimer>
#include <memory>

#include "display_area.h"
#include "main_window.h"
#include "message_presenter.h"
#include "mrsns/core/data_dir.h"
#include "mrsns/core/log.h"

int main(int argc, char** argv) {
  QElapsedTimer startup;
  startup.start();
  mrsns::gui::prepareOpenGlSurfaceFormat();
  QApplication app(argc, argv);
  QApplication::setOrganizationName(QStringLiteral("MR-SNS"));
  QApplication::setApplicationName(QStringLiteral("mrsns"));
  QApplication::setApplicationVersion(QString::fromStdString(mrsns::versionString()));

  QCommandLineParser parser;
  parser.setApplicationDescription(QStringLiteral("MR-SNS mixed-reality surgical navigation workstation"));
  parser.addHelpOption();
  parser.addVersionOption();
  parser.addPositionalArgument(QStringLiteral("session"), QStringLiteral("Session folder to open (default: the "
                                                                         "bundled sample session)"));
  const QCommandLineOption screenshot(QStringLiteral("screenshot"),
                                      QStringLiteral("Render the window to PNG once the session is shown, then exit."),
                                      QStringLiteral("png"));
  const QCommandLineOption size(QStringLiteral("size"), QStringLiteral("Window size WxH (default 1440x900)."),
                                QStringLiteral("WxH"));
  const QCommandLineOption log_level(QStringLiteral("log-level"),
                                     QStringLiteral("trace, debug, info, warn, error, critical or off."),
                                     QStringLiteral("level"), QStringLiteral("info"));
  parser.addOption(screenshot);
  parser.addOption(size);
  parser.addOption(log_level);
  parser.process(app);
  try {
    mrsns::setLogLevel(parser.value(log_level).toStdString());
  } catch (const std::exception& e) {
    fprintf(stderr, "mrsns: %s\n", e.what());
    return 2;
  }

  const bool headless_shot = parser.isSet(screenshot);
  mrsns::gui::MainWindowOptions options;
  std::shared_ptr<mrsns::gui::RecordingPresenter> recorder;
  if (headless_shot) {
    // A screenshot run must never wait for a click on a dialog.
    recorder = std::make_shared<mrsns::gui::RecordingPresenter>();
    options.presenter = recorder;
    options.remember_window_state = false;
  }
  mrsns::gui::MainWindow window(options);
  if (parser.isSet(size)) {
    const QStringList wh = parser.value(size).split(QLatin1Char('x'));
    if (wh.size() != 2 || wh[0].toInt() < 320 || wh[1].toInt() < 240) {
      fprintf(stderr, "mrsns: --size expects WxH, e.g. 1440x900 (at least 320x240)\n");
      return 2;
    }
    window.resize(wh[0].toInt(), wh[1].toInt());
  }
  window.show();
  const QStringList args = parser.positionalArguments();
  const bool opened = args.isEmpty() ? window.openSampleSession() : window.openSession(args.first());
  mrsns::logger()->info("mrsns started in {} ms (session {})", startup.elapsed(),
                        opened ? window.sessionFolder().toStdString() : std::string("none"));

  if (headless_shot) {
    const QString png = parser.value(screenshot);
    int status = 0;
    // Let the window lay out and the OpenGL views draw once before grabbing.
    QTimer::singleShot(300, &window, [&] {
      status = window.saveScreenshot(png) ? 0 : 1;
      for (const auto& m : recorder->messages) {
        fprintf(stderr, "mrsns: %s: %s\n", m.title.toUtf8().constData(), m.text.toUtf8().constData());
      }
      if (!opened) status = 1;
      window.close();
      QApplication::exit(status);
    });
    return QApplication::exec() == 0 ? status : 1;
  }
  return QApplication::exec();
}
