// LeakSanitizer and Mesa's drivers (the debug-asan preset only). eglTerminate and OSMesa unload
// Mesa's driver (swrast_dri.so, loaded by libEGL_mesa / libOSMesa), and the driver leaves a few
// allocations of its own behind (240 bytes in three blocks here). Once it is unloaded, the blocks
// are unreachable and their stacks are in "<unknown module>", which no suppression can name, so
// every GL test failed at exit. Before the first test this environment makes one context of
// each backend and pins every Mesa module then loaded (RTLD_NOLOAD | RTLD_NODELETE: the later
// dlclose keeps it mapped), so that what the driver still holds at exit is seen from its own
// globals and module (cmake/lsan-suppressions.txt names Mesa's libraries, nothing of nvstim).
#if defined(__SANITIZE_ADDRESS__)

#include <dlfcn.h>
#include <gtest/gtest.h>
#include <link.h>

#include <cstring>
#include <string>

#include "sim/render/gl_context.h"

namespace {

int pinMesaModule(dl_phdr_info* info, size_t, void*) {
    const char* name = info->dlpi_name;
    if (name == nullptr || name[0] == '\0') return 0;
    if (std::strstr(name, "_dri.so") || std::strstr(name, "libgallium") ||
        std::strstr(name, "libOSMesa") || std::strstr(name, "libEGL_mesa") ||
        std::strstr(name, "libglapi")) {
        (void)dlopen(name, RTLD_NOW | RTLD_NOLOAD | RTLD_NODELETE);
    }
    return 0;
}

class PinMesaDrivers : public ::testing::Environment {
  public:
    void SetUp() override {
        std::string why;
        auto egl = nvs::render::createEglContext(false, &why);
        if (egl) dl_iterate_phdr(&pinMesaModule, nullptr);
        auto os = nvs::render::createOsMesaContext(&why);
        if (os) dl_iterate_phdr(&pinMesaModule, nullptr);
    }
};

[[maybe_unused]] ::testing::Environment* const kPin =
    ::testing::AddGlobalTestEnvironment(new PinMesaDrivers);

}  // namespace

#endif
