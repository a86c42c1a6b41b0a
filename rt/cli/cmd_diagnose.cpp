#include "rt/cli/commands.h"

namespace nvs::cli {

int runDiagnose(const DiagnoseOptions& /*opts*/) {
    return notImplemented("diagnose");
}

}  // namespace nvs::cli
