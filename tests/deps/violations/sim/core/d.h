#include "drivers/sinks/sinks.h"
