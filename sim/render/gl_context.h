#pragma once
// Offscreen OpenGL contexts for sim/render/gl_visibility (internal to sim/render). Each backend
// loads its library at run time (dlopen), so a machine without it builds and runs: creating the
// context then fails with a reason string instead of a missing-library error at start-up.
//   EGL, device platform  a GPU found through EGL_EXT_device_enumeration and
//                         EGL_EXT_platform_device (Mesa's software device is skipped)
//   EGL, surfaceless      Mesa's EGL_MESA_platform_surfaceless (llvmpipe without a GPU)
//   OSMesa                Mesa's off-screen library (libOSMesa.so.8, Debian libosmesa6)
// All ask for an OpenGL 4.5 core profile (glClipControl for the reversed-Z depth buffer) and
// render into a framebuffer object, never a window or pbuffer surface.

#include <memory>
#include <string>

namespace nvs::render {

enum class GlBackend { kNone, kEglDevice, kEglSurfaceless, kOsMesa };

// "egl-device", "egl-surfaceless", "osmesa" or "none".
const char* glBackendName(GlBackend b) noexcept;

class GlContext {
  public:
    virtual ~GlContext() = default;
    // Makes the context current on the calling thread when it is not already. False on failure.
    virtual bool makeCurrent() noexcept = 0;
    // Releases the context from the calling thread (so another thread can make it current).
    virtual void release() noexcept = 0;
    // Address of a GL function (core or extension), nullptr when absent.
    virtual void* proc(const char* name) const noexcept = 0;
    GlBackend backend() const noexcept { return backend_; }

  protected:
    explicit GlContext(GlBackend b) : backend_(b) {}

  private:
    GlBackend backend_;
};

// Each returns nullptr and sets *reason (one line) when the backend cannot be created.
// gpuOnly: only an EGL device that is not Mesa's software renderer (kEglDevice); otherwise Mesa's
// surfaceless platform (kEglSurfaceless).
std::unique_ptr<GlContext> createEglContext(bool gpuOnly, std::string* reason);
std::unique_ptr<GlContext> createOsMesaContext(std::string* reason);

}  // namespace nvs::render
