#include "rt/cli/commands.h"

namespace nvs::cli {

int runEphem(const EphemOptions& /*opts*/) {
    return notImplemented("ephem");
}

}  // namespace nvs::cli
