// probestudio: the command-line face of the pipeline (place -> bake -> eval, and the stage tools).
// Errors from bad input are ps::Error, caught here once: one line on stderr, exit 1.
#include <cstdio>
#include <exception>

#include "app/cli/Common.h"
#include "core/common/Error.h"

int main(int argc, char** argv) {
  CLI::App app{"ProbeStudio: light-probe placement, capture and baking for glTF scenes"};
  app.require_subcommand(1);
  app.set_version_flag("--version", PS_CLI_VERSION);
  ps::cli::registerPlace(app);
  ps::cli::registerBake(app);
  ps::cli::registerCapture(app);
  ps::cli::registerTetra(app);
  ps::cli::registerQuery(app);
  ps::cli::registerEval(app);
  ps::cli::registerInfo(app);
  try {
    app.parse(argc, argv);
  } catch (const CLI::ParseError& e) {
    return app.exit(e);
  } catch (const ps::Error& e) {
    std::fprintf(stderr, "probestudio: error: %s\n", e.what());
    return 1;
  } catch (const std::exception& e) {
    std::fprintf(stderr, "probestudio: internal error: %s\n", e.what());
    return 3;
  }
  return 0;
}
