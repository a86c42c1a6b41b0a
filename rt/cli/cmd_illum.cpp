#include "rt/cli/commands.h"

namespace nvs::cli {

int runIllum(const IllumOptions& /*opts*/) {
    return notImplemented("illum");
}

}  // namespace nvs::cli
