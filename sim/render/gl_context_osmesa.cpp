// OSMesa backend of GlContext (gl_context.h): Mesa's off-screen rendering library, software
// (llvmpipe) on any machine. libOSMesa.so.8 (Debian libosmesa6) is loaded with dlopen so that
// nvstim runs where it is absent. Reference: Mesa's include/GL/osmesa.h (OSMesa 11.2 API:
// OSMesaCreateContextAttribs with OSMESA_PROFILE / OSMESA_CONTEXT_MAJOR_VERSION, a core profile
// from Mesa 12 on; OSMesaGetProcAddress for every GL entry point).

#include <dlfcn.h>

#include <array>
#include <cstdint>
#include <string>

#include "sim/render/gl_context.h"

#if __has_include(<GL/osmesa.h>)
#include <GL/osmesa.h>
#define NVS_HAVE_OSMESA_H 1
#endif

namespace nvs::render {

#ifdef NVS_HAVE_OSMESA_H
namespace {

struct OsMesaApi {
    using CreateFn = OSMesaContext (*)(const int*, OSMesaContext);
    using DestroyFn = void (*)(OSMesaContext);
    using MakeCurrentFn = GLboolean (*)(OSMesaContext, void*, GLenum, GLsizei, GLsizei);
    using GetCurrentFn = OSMesaContext (*)();
    using GetProcFn = OSMESAproc (*)(const char*);
    CreateFn create = nullptr;
    DestroyFn destroy = nullptr;
    MakeCurrentFn makeCurrent = nullptr;
    GetCurrentFn getCurrent = nullptr;
    GetProcFn getProc = nullptr;

    bool load(std::string* reason) {
        void* lib = dlopen("libOSMesa.so.8", RTLD_NOW | RTLD_LOCAL);
        if (lib == nullptr) {
            *reason = std::string("OSMesa: cannot load libOSMesa.so.8 (") + dlerror() + ")";
            return false;
        }
        create = reinterpret_cast<CreateFn>(dlsym(lib, "OSMesaCreateContextAttribs"));
        destroy = reinterpret_cast<DestroyFn>(dlsym(lib, "OSMesaDestroyContext"));
        makeCurrent = reinterpret_cast<MakeCurrentFn>(dlsym(lib, "OSMesaMakeCurrent"));
        getCurrent = reinterpret_cast<GetCurrentFn>(dlsym(lib, "OSMesaGetCurrentContext"));
        getProc = reinterpret_cast<GetProcFn>(dlsym(lib, "OSMesaGetProcAddress"));
        if (!create || !destroy || !makeCurrent || !getCurrent || !getProc) {
            *reason = "OSMesa: libOSMesa.so.8 lacks OSMesaCreateContextAttribs (Mesa < 11.2)";
            return false;
        }
        return true;
    }
};

class OsMesaContext final : public GlContext {
  public:
    OsMesaContext(OsMesaApi api, OSMesaContext ctx)
        : GlContext(GlBackend::kOsMesa), api_(api), ctx_(ctx) {}
    ~OsMesaContext() override {
        if (api_.getCurrent() == ctx_) api_.makeCurrent(nullptr, nullptr, 0, 0, 0);
        api_.destroy(ctx_);
    }
    // OSMesa binds a colour buffer with the context; rendering goes to a framebuffer object, so
    // a 1 × 1 buffer stands for the window.
    bool makeCurrent() noexcept override {
        if (api_.getCurrent() == ctx_) return true;
        return api_.makeCurrent(ctx_, pixel_.data(), GL_UNSIGNED_BYTE, 1, 1) == GL_TRUE;
    }
    void release() noexcept override {
        if (api_.getCurrent() == ctx_) api_.makeCurrent(nullptr, nullptr, 0, 0, 0);
    }
    void* proc(const char* name) const noexcept override {
        return reinterpret_cast<void*>(api_.getProc(name));
    }

  private:
    OsMesaApi api_;
    OSMesaContext ctx_;
    std::array<std::uint8_t, 4> pixel_{};
};

}  // namespace

std::unique_ptr<GlContext> createOsMesaContext(std::string* reason) {
    OsMesaApi api;
    if (!api.load(reason)) return nullptr;
    const int attr[] = {OSMESA_FORMAT,
                        OSMESA_RGBA,
                        OSMESA_DEPTH_BITS,
                        0,
                        OSMESA_PROFILE,
                        OSMESA_CORE_PROFILE,
                        OSMESA_CONTEXT_MAJOR_VERSION,
                        4,
                        OSMESA_CONTEXT_MINOR_VERSION,
                        5,
                        0};
    OSMesaContext ctx = api.create(attr, nullptr);
    if (ctx == nullptr) {
        *reason = "OSMesa: cannot create an OpenGL 4.5 core context";
        return nullptr;
    }
    return std::make_unique<OsMesaContext>(api, ctx);
}
#else
std::unique_ptr<GlContext> createOsMesaContext(std::string* reason) {
    *reason = "OSMesa: built without GL/osmesa.h (Debian libosmesa6-dev)";
    return nullptr;
}
#endif

}  // namespace nvs::render
