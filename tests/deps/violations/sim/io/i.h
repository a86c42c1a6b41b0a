#pragma once
#include "sim/msg/output.h"
