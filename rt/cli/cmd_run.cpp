#include "rt/cli/commands.h"

namespace nvs::cli {

int runRun(const RunOptions& /*opts*/) {
    return notImplemented("run");
}

}  // namespace nvs::cli
