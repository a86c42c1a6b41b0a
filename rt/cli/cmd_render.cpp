#include "rt/cli/commands.h"

namespace nvs::cli {

int runRender(const RenderOptions& /*opts*/) {
    return notImplemented("render");
}

}  // namespace nvs::cli
