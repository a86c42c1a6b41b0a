#include "rt/cli/commands.h"

namespace nvs::cli {

int runReplay(const ReplayOptions& /*opts*/) {
    return notImplemented("replay");
}

}  // namespace nvs::cli
