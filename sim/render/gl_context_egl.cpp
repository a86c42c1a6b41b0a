// EGL backends of GlContext (gl_context.h): a GPU through EGL_EXT_device_enumeration +
// EGL_EXT_platform_device, or Mesa's surfaceless platform. libEGL.so.1 (glvnd, Debian libegl1,
// with Mesa's vendor library libegl-mesa0) is loaded with dlopen so that nvstim runs where it is
// absent. References: EGL 1.5 specification (Khronos, 2014) §3.2 initialisation, §3.7 context
// creation and eglMakeCurrent with EGL_NO_SURFACE (EGL_KHR_surfaceless_context); extension
// specifications EGL_EXT_device_enumeration, EGL_EXT_device_query, EGL_EXT_platform_device,
// EGL_MESA_platform_surfaceless, EGL_MESA_device_software (registry.khronos.org/EGL).

#include <EGL/egl.h>
#include <EGL/eglext.h>
#include <dlfcn.h>

#include <cstdio>
#include <cstring>
#include <string>

#include "sim/render/gl_context.h"

#ifndef EGL_PLATFORM_SURFACELESS_MESA
#define EGL_PLATFORM_SURFACELESS_MESA 0x31DD
#endif

namespace nvs::render {

namespace {

// The EGL entry points used, resolved from libEGL.so.1.
struct EglApi {
    void* lib = nullptr;
    PFNEGLGETPROCADDRESSPROC getProcAddress = nullptr;
    PFNEGLQUERYSTRINGPROC queryString = nullptr;
    PFNEGLINITIALIZEPROC initialize = nullptr;
    PFNEGLTERMINATEPROC terminate = nullptr;
    PFNEGLBINDAPIPROC bindApi = nullptr;
    PFNEGLCHOOSECONFIGPROC chooseConfig = nullptr;
    PFNEGLCREATECONTEXTPROC createContext = nullptr;
    PFNEGLDESTROYCONTEXTPROC destroyContext = nullptr;
    PFNEGLMAKECURRENTPROC makeCurrent = nullptr;
    PFNEGLGETCURRENTCONTEXTPROC getCurrentContext = nullptr;
    PFNEGLGETERRORPROC getError = nullptr;
    PFNEGLQUERYDEVICESEXTPROC queryDevices = nullptr;
    PFNEGLQUERYDEVICESTRINGEXTPROC queryDeviceString = nullptr;
    PFNEGLGETPLATFORMDISPLAYEXTPROC getPlatformDisplay = nullptr;

    bool load(std::string* reason) {
        lib = dlopen("libEGL.so.1", RTLD_NOW | RTLD_LOCAL);
        if (lib == nullptr) {
            *reason = std::string("EGL: cannot load libEGL.so.1 (") + dlerror() + ")";
            return false;
        }
        const auto sym = [&](const char* name) { return dlsym(lib, name); };
        getProcAddress = reinterpret_cast<PFNEGLGETPROCADDRESSPROC>(sym("eglGetProcAddress"));
        queryString = reinterpret_cast<PFNEGLQUERYSTRINGPROC>(sym("eglQueryString"));
        initialize = reinterpret_cast<PFNEGLINITIALIZEPROC>(sym("eglInitialize"));
        terminate = reinterpret_cast<PFNEGLTERMINATEPROC>(sym("eglTerminate"));
        bindApi = reinterpret_cast<PFNEGLBINDAPIPROC>(sym("eglBindAPI"));
        chooseConfig = reinterpret_cast<PFNEGLCHOOSECONFIGPROC>(sym("eglChooseConfig"));
        createContext = reinterpret_cast<PFNEGLCREATECONTEXTPROC>(sym("eglCreateContext"));
        destroyContext = reinterpret_cast<PFNEGLDESTROYCONTEXTPROC>(sym("eglDestroyContext"));
        makeCurrent = reinterpret_cast<PFNEGLMAKECURRENTPROC>(sym("eglMakeCurrent"));
        getCurrentContext =
            reinterpret_cast<PFNEGLGETCURRENTCONTEXTPROC>(sym("eglGetCurrentContext"));
        getError = reinterpret_cast<PFNEGLGETERRORPROC>(sym("eglGetError"));
        if (!getProcAddress || !queryString || !initialize || !terminate || !bindApi ||
            !chooseConfig || !createContext || !destroyContext || !makeCurrent ||
            !getCurrentContext || !getError) {
            *reason = "EGL: libEGL.so.1 lacks an EGL 1.4 entry point";
            return false;
        }
        queryDevices =
            reinterpret_cast<PFNEGLQUERYDEVICESEXTPROC>(getProcAddress("eglQueryDevicesEXT"));
        queryDeviceString = reinterpret_cast<PFNEGLQUERYDEVICESTRINGEXTPROC>(
            getProcAddress("eglQueryDeviceStringEXT"));
        getPlatformDisplay = reinterpret_cast<PFNEGLGETPLATFORMDISPLAYEXTPROC>(
            getProcAddress("eglGetPlatformDisplayEXT"));
        return true;
    }
};

bool hasWord(const char* list, const char* word) {
    if (list == nullptr) return false;
    const std::size_t n = std::strlen(word);
    for (const char* p = std::strstr(list, word); p != nullptr; p = std::strstr(p + 1, word)) {
        if ((p == list || p[-1] == ' ') && (p[n] == ' ' || p[n] == '\0')) return true;
    }
    return false;
}

class EglContext final : public GlContext {
  public:
    EglContext(GlBackend b, EglApi api, EGLDisplay dpy, EGLContext ctx)
        : GlContext(b), api_(api), dpy_(dpy), ctx_(ctx) {}
    ~EglContext() override {
        if (api_.getCurrentContext() == ctx_) {
            api_.makeCurrent(dpy_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        }
        api_.destroyContext(dpy_, ctx_);
        api_.terminate(dpy_);
        // libEGL stays loaded: drivers register atexit handlers and thread-local state.
    }
    bool makeCurrent() noexcept override {
        if (api_.getCurrentContext() == ctx_) return true;
        return api_.makeCurrent(dpy_, EGL_NO_SURFACE, EGL_NO_SURFACE, ctx_) == EGL_TRUE;
    }
    void release() noexcept override {
        if (api_.getCurrentContext() == ctx_) {
            api_.makeCurrent(dpy_, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
        }
    }
    void* proc(const char* name) const noexcept override {
        return reinterpret_cast<void*>(api_.getProcAddress(name));
    }

  private:
    EglApi api_;
    EGLDisplay dpy_;
    EGLContext ctx_;
};

// Initialises dpy and creates an OpenGL 4.5 core context without a surface on it.
std::unique_ptr<GlContext> contextOn(const EglApi& api, EGLDisplay dpy, GlBackend b,
                                     std::string* reason) {
    EGLint major = 0, minor = 0;
    if (dpy == EGL_NO_DISPLAY || api.initialize(dpy, &major, &minor) != EGL_TRUE) {
        *reason = "EGL: cannot initialise the display";
        return nullptr;
    }
    const char* ext = api.queryString(dpy, EGL_EXTENSIONS);
    if (!hasWord(ext, "EGL_KHR_surfaceless_context")) {
        api.terminate(dpy);
        *reason = "EGL: display lacks EGL_KHR_surfaceless_context";
        return nullptr;
    }
    if (api.bindApi(EGL_OPENGL_API) != EGL_TRUE) {
        api.terminate(dpy);
        *reason = "EGL: display does not offer desktop OpenGL";
        return nullptr;
    }
    // EGL_SURFACE_TYPE defaults to EGL_WINDOW_BIT, which surfaceless displays lack: 0 takes
    // any config (no surface is ever made).
    const EGLint cfgAttr[] = {EGL_RENDERABLE_TYPE, EGL_OPENGL_BIT, EGL_SURFACE_TYPE, 0, EGL_NONE};
    EGLConfig cfg = nullptr;
    EGLint count = 0;
    if (api.chooseConfig(dpy, cfgAttr, &cfg, 1, &count) != EGL_TRUE || count < 1) {
        api.terminate(dpy);
        *reason = "EGL: no OpenGL config";
        return nullptr;
    }
    const EGLint ctxAttr[] = {EGL_CONTEXT_MAJOR_VERSION,
                              4,
                              EGL_CONTEXT_MINOR_VERSION,
                              5,
                              EGL_CONTEXT_OPENGL_PROFILE_MASK,
                              EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                              EGL_NONE};
    EGLContext ctx = api.createContext(dpy, cfg, EGL_NO_CONTEXT, ctxAttr);
    if (ctx == EGL_NO_CONTEXT) {
        char err[64];
        std::snprintf(err, sizeof err, "EGL: cannot create an OpenGL 4.5 core context (0x%04x)",
                      static_cast<unsigned>(api.getError()));
        *reason = err;
        api.terminate(dpy);
        return nullptr;
    }
    return std::make_unique<EglContext>(b, api, dpy, ctx);
}

std::unique_ptr<GlContext> deviceContext(const EglApi& api, std::string* reason) {
    const char* client = api.queryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!api.queryDevices || !api.queryDeviceString || !api.getPlatformDisplay ||
        !hasWord(client, "EGL_EXT_platform_device")) {
        *reason = "EGL: no device enumeration (EGL_EXT_device_enumeration, platform_device)";
        return nullptr;
    }
    constexpr int kMaxDevices = 16;
    EGLDeviceEXT devices[kMaxDevices];
    EGLint n = 0;
    if (api.queryDevices(kMaxDevices, devices, &n) != EGL_TRUE) n = 0;
    std::string why = "EGL: no GPU device (" + std::to_string(n) + " device(s), all software)";
    for (EGLint k = 0; k < n; ++k) {
        // Mesa's llvmpipe device names itself with EGL_MESA_device_software.
        if (hasWord(api.queryDeviceString(devices[k], EGL_EXTENSIONS),
                    "EGL_MESA_device_software")) {
            continue;
        }
        EGLDisplay dpy = api.getPlatformDisplay(EGL_PLATFORM_DEVICE_EXT, devices[k], nullptr);
        std::unique_ptr<GlContext> c = contextOn(api, dpy, GlBackend::kEglDevice, &why);
        if (c) return c;
    }
    *reason = why;
    return nullptr;
}

std::unique_ptr<GlContext> surfacelessContext(const EglApi& api, std::string* reason) {
    const char* client = api.queryString(EGL_NO_DISPLAY, EGL_EXTENSIONS);
    if (!api.getPlatformDisplay || !hasWord(client, "EGL_MESA_platform_surfaceless")) {
        *reason = "EGL: no EGL_MESA_platform_surfaceless (Mesa's EGL, libegl-mesa0, absent)";
        return nullptr;
    }
    EGLDisplay dpy =
        api.getPlatformDisplay(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    return contextOn(api, dpy, GlBackend::kEglSurfaceless, reason);
}

}  // namespace

const char* glBackendName(GlBackend b) noexcept {
    switch (b) {
        case GlBackend::kEglDevice:
            return "egl-device";
        case GlBackend::kEglSurfaceless:
            return "egl-surfaceless";
        case GlBackend::kOsMesa:
            return "osmesa";
        case GlBackend::kNone:
            break;
    }
    return "none";
}

std::unique_ptr<GlContext> createEglContext(bool gpuOnly, std::string* reason) {
    EglApi api;
    if (!api.load(reason)) return nullptr;
    std::unique_ptr<GlContext> c =
        gpuOnly ? deviceContext(api, reason) : surfacelessContext(api, reason);
    if (c) c->release();
    return c;
}

}  // namespace nvs::render
