#include "rt/clock/threads.h"

#include <pthread.h>

#include "rt/clock/clock.h"

namespace nvs::rt {

int applyThreadSpec(ThreadId id, bool realtime, std::string& message) {
    const ThreadSpec& spec = kThreadTable[id];
    pthread_setname_np(pthread_self(), spec.name);
    if (!realtime || spec.fifoPriority <= 0) return 0;
    return makeThreadRealtime(spec.fifoPriority, spec.cpu, message);
}

}  // namespace nvs::rt
