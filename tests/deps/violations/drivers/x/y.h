#pragma once
#include "sim/sensor/chain.h"
