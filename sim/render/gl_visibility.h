#pragma once
// Primary visibility by rasterisation (OpenGL): for a pinhole camera and a set of triangle
// meshes, which triangle each pixel's centre ray meets first — the same answer as casting the
// primary rays with Embree (rtcIntersect), at a fraction of the cost on a GPU. The renderer's
// G-buffer is then built from it by the code that builds it from Embree's hits (primary.cpp);
// Embree keeps the shadow, lamp and mirror rays.
//
// The pass (one draw per mesh into a framebuffer object, read back with glReadPixels):
//   colour 0, R32UI      the triangle's id + 1 (0: miss): the mesh's first id + gl_PrimitiveID
//                        (the triangle's index in its mesh), ids numbered over the meshes in
//                        the order they were added
//   depth, 32-bit float  reversed Z (depth = near/z_camera, glClipControl ZERO_TO_ONE,
//                        GL_GREATER): relative depth resolution ≈ 2⁻²⁴ at every range
// Only the id is read back (4 bytes a pixel: 8.3 MB at 1920 × 1080; the read-back, not the draw,
// is what a GPU pass costs): the hit point follows on the CPU from the pixel-centre ray and the
// triangle, in double precision (rayPlaneOfTriangle, sim/core/geometry.h): Embree's barycentrics
// u and v (the weights of the triangle's vertices 1 and 2) and the distance t along the unit
// ray, as hit() does here and the renderer's G-buffer pass does with its own vertex buffers.
//
// Pixels, projection and row order are the renderer's (Renderer::Impl::pixelDir/project):
// pixel (x, y) is sampled at its centre (x + ½, y + ½), x along `right`, y along −`up`, row 0 at
// the top. The clip transform maps image row y to GL window row y (GL's window origin is at the
// bottom), so glReadPixels returns the image's rows in the image's order and gl_FragCoord is the
// image's pixel position. Triangles are drawn from both sides (no culling), as Embree meets
// them. Geometry nearer than kNear_m to the camera is clipped (Embree's primary rays start at 0).
// Pixels whose centre lies on a triangle edge can differ from Embree's (GL's top-left fill rule
// against Embree's watertight test), as can pixels where two surfaces are within the depth
// resolution of each other.
//
// Two phases: create() and addMesh() at setup (they allocate; addMesh throws SetupError);
// setVertices(), setEnabled() and render() per frame: noexcept, no allocation, a status back.

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sim/core/geometry.h"
#include "sim/render/gl_context.h"

namespace nvs::render {

// A pinhole view (the renderer's PinholeCamera and camera frame; unit vectors, scene frame).
struct GlView {
    int width = 0, height = 0;
    double focalLength_m = 0.0, pitchX_m = 0.0, pitchY_m = 0.0;
    Vec3 position_m, forward, right, up;
};

// One pixel's answer: geomId kGlMiss on a miss.
inline constexpr std::uint32_t kGlMiss = 0xFFFFFFFFu;
struct GlHit {
    std::uint32_t geomId = kGlMiss;
    std::uint32_t primId = 0;
    double u = 0.0, v = 0.0;  // weights of vertices 1 and 2 (Embree's hit.u, hit.v)
    double t_m = 0.0;         // along the unit pixel-centre ray
};

enum class GlStatus { kOk, kNotCurrent, kBadRect, kGlError };
const char* glStatusName(GlStatus s) noexcept;

// Which context to make: kAuto tries an EGL GPU device, then EGL surfaceless, then OSMesa.
enum class GlBackendChoice { kAuto, kEglDevice, kEglSurfaceless, kOsMesa };

class GlVisibility {
  public:
    static constexpr double kNear_m = 1e-3;

    // A context and a width × height target. nullptr with *reason (one line per backend tried)
    // when no backend works; never throws for a missing or failing library.
    static std::unique_ptr<GlVisibility> create(GlBackendChoice choice, int width, int height,
                                                std::string* reason);
    ~GlVisibility();
    GlVisibility(const GlVisibility&) = delete;
    GlVisibility& operator=(const GlVisibility&) = delete;

    GlBackend backend() const noexcept { return backend_; }
    // GL_RENDERER and GL_VERSION of the context, e.g. "llvmpipe (LLVM 15.0.6, 256 bits), 4.5".
    const std::string& description() const noexcept { return description_; }
    int width() const noexcept { return width_; }
    int height() const noexcept { return height_; }

    // Setup: a mesh of vertexCount world vertices (xyz floats) and triangleCount index triples;
    // its pixels report geomId. Returns the mesh's handle (0, 1, ...). Throws SetupError.
    int addMesh(const float* vertices_m, std::size_t vertexCount, const std::uint32_t* indices,
                std::size_t triangleCount, std::uint32_t geomId);
    // Per frame: new world positions of a mesh's vertices (as many as at addMesh).
    GlStatus setVertices(int mesh, const float* vertices_m) noexcept;
    void setEnabled(int mesh, bool enabled) noexcept;

    // Renders the rectangle [x0, x1) × [y0, y1) of the image (scissored) and reads it back into
    // the result buffers; pixels outside keep what they had. The context is made current on the
    // calling thread if it is not.
    GlStatus render(const GlView& view, int x0, int y0, int x1, int y1) noexcept;
    GlStatus render(const GlView& view) noexcept { return render(view, 0, 0, width_, height_); }

    // Releases the context from the calling thread, so that another thread can render (setup
    // work done on one thread before the frame loop's thread takes over).
    void releaseContext() noexcept { ctx_->release(); }

    // Wall time of the last render() [ms]: the draw and the read-back into the result buffers
    // (the G-buffer built from them is the caller's; docs/performance.md splits the two).
    double lastRender_ms() const noexcept { return lastRender_ms_; }

    // The hit at pixel (x, y) of the last render (row 0 at the top), the point on the triangle
    // computed for the last render's view from the mesh's vertices as last set.
    GlHit hit(int x, int y) const noexcept;
    // Raw: one word per pixel, row-major, row 0 at the top: 0 (miss) or a triangle's id + 1.
    const std::uint32_t* ids() const noexcept { return ids_.data(); }
    // The mesh whose triangle a raw word names: its ids are [firstId, firstId + count), its
    // triangle k has id firstId + k (count 0: 0, a miss, or a word no mesh holds). Neighbouring
    // pixels mostly see the same mesh: a caller keeps the last range and looks up only when
    // word − 1 − firstId ≥ count.
    struct IdRange {
        std::uint32_t firstId = 0, count = 0, geomId = kGlMiss;
    };
    IdRange idRange(std::uint32_t word) const noexcept;

    struct Gl;  // the GL entry points (gl_visibility.cpp)

  private:
    GlVisibility() = default;
    bool init(std::unique_ptr<GlContext> ctx, int width, int height, std::string* reason);
    struct Mesh {
        unsigned vao = 0, vbo = 0;
        std::vector<std::uint32_t> indices;
        std::vector<float> vertices_m;  // as last set (hit())
        std::uint32_t firstId = 0;      // the id of its triangle 0
        std::uint32_t geomId = 0;
        bool enabled = true;
    };
    // The mesh holding a raw word's triangle (nullptr: a miss or a word no mesh holds).
    const Mesh* meshOf(std::uint32_t word) const noexcept;
    std::unique_ptr<GlContext> ctx_;
    std::unique_ptr<Gl> gl_;
    GlBackend backend_ = GlBackend::kNone;
    std::string description_;
    int width_ = 0, height_ = 0;
    double lastRender_ms_ = 0.0;
    unsigned fbo_ = 0, colorIds_ = 0, depth_ = 0, program_ = 0;
    int uCamPos_ = -1, uRight_ = -1, uUp_ = -1, uFwd_ = -1, uScale_ = -1, uNear_ = -1;
    int uFirstId_ = -1;
    std::vector<Mesh> meshes_;
    std::uint32_t nextId_ = 0;    // the id the next mesh's triangle 0 gets
    std::vector<float> staging_;  // de-indexed vertices of the largest mesh
    std::vector<std::uint32_t> ids_;
    GlView lastView_;
};

}  // namespace nvs::render
