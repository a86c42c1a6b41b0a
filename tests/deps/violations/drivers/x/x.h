#include "rt/loop/stages.h"
