#include "rt/cli/commands.h"

namespace nvs::cli {

int runSensor(const SensorOptions& /*opts*/) {
    return notImplemented("sensor");
}

}  // namespace nvs::cli
