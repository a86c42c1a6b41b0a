#include "sim/sensor/camera.h"
