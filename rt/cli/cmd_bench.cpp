#include "rt/cli/commands.h"

namespace nvs::cli {

int runBench(const BenchOptions& /*opts*/) {
    return notImplemented("bench");
}

}  // namespace nvs::cli
