// Primary visibility by rasterisation (gl_visibility.h has the contract). OpenGL 4.5 core
// profile; references: OpenGL 4.5 core specification (Khronos, 2017) §13.7 (clip control),
// §14.6 (polygon rasterisation: pixel centres, the fill rule, perspective-correct
// interpolation, eq. 14.9), §17.4.4 (integer colour buffers and glClearBuffer), §18.2
// (glReadPixels, integer formats); GLSL 4.50 §7.1 (gl_FragCoord at pixel centres,
// gl_PrimitiveID counting the draw's primitives from 0, gl_VertexID). Reversed Z: E. Persson,
// "Depth Precision" (Humus, 2012) and NVIDIA, "Depth Precision Visualized" (N. Reed, 2015).
//
// Written here rather than taken from a library: the pass is two small shaders and a dozen GL
// calls; a loader (libepoxy, GLEW) would add a dependency for the function pointers alone, and
// none offers the pixel-exact match to the renderer's camera this needs.

#include "sim/render/gl_visibility.h"

#include <GL/glcorearb.h>

#include <algorithm>
#include <chrono>
#include <cstring>

#include "sim/core/error.h"

namespace nvs::render {

// The GL entry points used, resolved from the context (eglGetProcAddress/OSMesaGetProcAddress).
#define NVS_GL_FUNCTIONS(X)                                      \
    X(PFNGLGETSTRINGPROC, GetString)                             \
    X(PFNGLGETERRORPROC, GetError)                               \
    X(PFNGLENABLEPROC, Enable)                                   \
    X(PFNGLDISABLEPROC, Disable)                                 \
    X(PFNGLDEPTHFUNCPROC, DepthFunc)                             \
    X(PFNGLCLIPCONTROLPROC, ClipControl)                         \
    X(PFNGLVIEWPORTPROC, Viewport)                               \
    X(PFNGLSCISSORPROC, Scissor)                                 \
    X(PFNGLPIXELSTOREIPROC, PixelStorei)                         \
    X(PFNGLREADBUFFERPROC, ReadBuffer)                           \
    X(PFNGLREADPIXELSPROC, ReadPixels)                           \
    X(PFNGLGENFRAMEBUFFERSPROC, GenFramebuffers)                 \
    X(PFNGLDELETEFRAMEBUFFERSPROC, DeleteFramebuffers)           \
    X(PFNGLBINDFRAMEBUFFERPROC, BindFramebuffer)                 \
    X(PFNGLCHECKFRAMEBUFFERSTATUSPROC, CheckFramebufferStatus)   \
    X(PFNGLGENRENDERBUFFERSPROC, GenRenderbuffers)               \
    X(PFNGLDELETERENDERBUFFERSPROC, DeleteRenderbuffers)         \
    X(PFNGLBINDRENDERBUFFERPROC, BindRenderbuffer)               \
    X(PFNGLRENDERBUFFERSTORAGEPROC, RenderbufferStorage)         \
    X(PFNGLFRAMEBUFFERRENDERBUFFERPROC, FramebufferRenderbuffer) \
    X(PFNGLDRAWBUFFERSPROC, DrawBuffers)                         \
    X(PFNGLCLEARBUFFERUIVPROC, ClearBufferuiv)                   \
    X(PFNGLCLEARBUFFERFVPROC, ClearBufferfv)                     \
    X(PFNGLCREATESHADERPROC, CreateShader)                       \
    X(PFNGLDELETESHADERPROC, DeleteShader)                       \
    X(PFNGLSHADERSOURCEPROC, ShaderSource)                       \
    X(PFNGLCOMPILESHADERPROC, CompileShader)                     \
    X(PFNGLGETSHADERIVPROC, GetShaderiv)                         \
    X(PFNGLGETSHADERINFOLOGPROC, GetShaderInfoLog)               \
    X(PFNGLCREATEPROGRAMPROC, CreateProgram)                     \
    X(PFNGLDELETEPROGRAMPROC, DeleteProgram)                     \
    X(PFNGLATTACHSHADERPROC, AttachShader)                       \
    X(PFNGLLINKPROGRAMPROC, LinkProgram)                         \
    X(PFNGLGETPROGRAMIVPROC, GetProgramiv)                       \
    X(PFNGLGETPROGRAMINFOLOGPROC, GetProgramInfoLog)             \
    X(PFNGLUSEPROGRAMPROC, UseProgram)                           \
    X(PFNGLGETUNIFORMLOCATIONPROC, GetUniformLocation)           \
    X(PFNGLUNIFORM1UIPROC, Uniform1ui)                           \
    X(PFNGLUNIFORM1FPROC, Uniform1f)                             \
    X(PFNGLUNIFORM2FPROC, Uniform2f)                             \
    X(PFNGLUNIFORM3FPROC, Uniform3f)                             \
    X(PFNGLGENVERTEXARRAYSPROC, GenVertexArrays)                 \
    X(PFNGLDELETEVERTEXARRAYSPROC, DeleteVertexArrays)           \
    X(PFNGLBINDVERTEXARRAYPROC, BindVertexArray)                 \
    X(PFNGLGENBUFFERSPROC, GenBuffers)                           \
    X(PFNGLDELETEBUFFERSPROC, DeleteBuffers)                     \
    X(PFNGLBINDBUFFERPROC, BindBuffer)                           \
    X(PFNGLBUFFERDATAPROC, BufferData)                           \
    X(PFNGLBUFFERSUBDATAPROC, BufferSubData)                     \
    X(PFNGLVERTEXATTRIBPOINTERPROC, VertexAttribPointer)         \
    X(PFNGLENABLEVERTEXATTRIBARRAYPROC, EnableVertexAttribArray) \
    X(PFNGLDRAWARRAYSPROC, DrawArrays)

struct GlVisibility::Gl {
#define NVS_GL_MEMBER(type, name) type name = nullptr;
    NVS_GL_FUNCTIONS(NVS_GL_MEMBER)
#undef NVS_GL_MEMBER
    // Resolves every entry point; false (with the first missing name) when one is absent.
    bool load(const GlContext& c, std::string* missing) {
#define NVS_GL_LOAD(type, name)                        \
    name = reinterpret_cast<type>(c.proc("gl" #name)); \
    if (name == nullptr) {                             \
        *missing = "gl" #name;                         \
        return false;                                  \
    }
        NVS_GL_FUNCTIONS(NVS_GL_LOAD)
#undef NVS_GL_LOAD
        return true;
    }
};

namespace {

// Vertex stage: camera-relative position r = p − o; clip coordinates
//   x_c = (r·right) · 2f/(p_x W),  y_c = −(r·up) · 2f/(p_y H),  z_c = near,  w_c = r·forward,
// so that x_ndc = 2u/W − 1 and y_ndc = 2v/H − 1 with (u, v) the renderer's pixel coordinates
// (Renderer::Impl::project): image row v lands on GL window row v. With glClipControl
// ZERO_TO_ONE the depth is near/z (reversed Z, infinite far plane) and the near plane z = near.
constexpr const char* kVertexShader = R"(#version 330 core
layout(location = 0) in vec3 pos_m;
uniform vec3 camPos_m, camRight, camUp, camFwd;
uniform vec2 clipScale;
uniform float near_m;
void main() {
    vec3 r = pos_m - camPos_m;
    gl_Position = vec4(dot(r, camRight) * clipScale.x, -dot(r, camUp) * clipScale.y, near_m,
                       dot(r, camFwd));
}
)";

// Fragment stage: the triangle's id + 1 (the mesh's first id + 1, then gl_PrimitiveID).
constexpr const char* kFragmentShader = R"(#version 330 core
uniform uint firstId1;
layout(location = 0) out uint id;
void main() {
    id = firstId1 + uint(gl_PrimitiveID);
}
)";

unsigned compile(const GlVisibility::Gl& gl, GLenum kind, const char* src, std::string* log) {
    const GLuint s = gl.CreateShader(kind);
    gl.ShaderSource(s, 1, &src, nullptr);
    gl.CompileShader(s);
    GLint ok = 0;
    gl.GetShaderiv(s, GL_COMPILE_STATUS, &ok);
    if (!ok) {
        char buf[1024] = {};
        gl.GetShaderInfoLog(s, sizeof buf, nullptr, buf);
        *log = buf;
        gl.DeleteShader(s);
        return 0;
    }
    return s;
}

// The program of the two shaders into *program; false with the compiler's or linker's log.
bool linkProgram(const GlVisibility::Gl& gl, unsigned* program, std::string* log) {
    const unsigned vs = compile(gl, GL_VERTEX_SHADER, kVertexShader, log);
    const unsigned fs = vs ? compile(gl, GL_FRAGMENT_SHADER, kFragmentShader, log) : 0;
    if (!vs || !fs) {
        *log = "shader: " + *log;
        return false;
    }
    *program = gl.CreateProgram();
    gl.AttachShader(*program, vs);
    gl.AttachShader(*program, fs);
    gl.LinkProgram(*program);
    gl.DeleteShader(vs);
    gl.DeleteShader(fs);
    GLint ok = 0;
    gl.GetProgramiv(*program, GL_LINK_STATUS, &ok);
    if (!ok) {
        char buf[1024] = {};
        gl.GetProgramInfoLog(*program, sizeof buf, nullptr, buf);
        *log = std::string("link: ") + buf;
        return false;
    }
    return true;
}

}  // namespace

const char* glStatusName(GlStatus s) noexcept {
    switch (s) {
        case GlStatus::kOk:
            return "ok";
        case GlStatus::kNotCurrent:
            return "context not current";
        case GlStatus::kBadRect:
            return "bad rectangle or mesh";
        case GlStatus::kGlError:
            return "GL error";
    }
    return "?";
}

std::unique_ptr<GlVisibility> GlVisibility::create(GlBackendChoice choice, int width, int height,
                                                   std::string* reason) {
    reason->clear();
    const auto attempt = [&](GlBackendChoice b) -> std::unique_ptr<GlVisibility> {
        std::string why;
        std::unique_ptr<GlContext> ctx;
        if (b == GlBackendChoice::kOsMesa) {
            ctx = createOsMesaContext(&why);
        } else {
            ctx = createEglContext(b == GlBackendChoice::kEglDevice, &why);
        }
        std::unique_ptr<GlVisibility> v;
        if (ctx) {
            v.reset(new GlVisibility());
            if (!v->init(std::move(ctx), width, height, &why)) v.reset();
        }
        if (!v) *reason += (reason->empty() ? "" : "; ") + why;
        return v;
    };
    if (width < 1 || height < 1) {
        *reason = "GL: image size must be positive";
        return nullptr;
    }
    if (choice != GlBackendChoice::kAuto) return attempt(choice);
    for (GlBackendChoice b : {GlBackendChoice::kEglDevice, GlBackendChoice::kEglSurfaceless,
                              GlBackendChoice::kOsMesa}) {
        if (auto v = attempt(b)) return v;
    }
    return nullptr;
}

// Loads the entry points, checks the version, builds the program and the framebuffer. Leaves
// the context released from the calling thread.
bool GlVisibility::init(std::unique_ptr<GlContext> ctx, int width, int height,
                        std::string* reason) {
    const char* name = glBackendName(ctx->backend());
    if (!ctx->makeCurrent()) {
        *reason = std::string(name) + ": cannot make the context current";
        return false;
    }
    ctx_ = std::move(ctx);
    backend_ = ctx_->backend();
    gl_ = std::make_unique<Gl>();
    std::string missing;
    if (!gl_->load(*ctx_, &missing)) {
        *reason = std::string(name) + ": no " + missing + " (OpenGL 4.5 needed)";
        return false;
    }
    const Gl& gl = *gl_;
    const auto str = [&](GLenum e) {
        const auto* s = reinterpret_cast<const char*>(gl.GetString(e));
        return std::string(s != nullptr ? s : "?");
    };
    description_ = str(GL_RENDERER) + ", OpenGL " + str(GL_VERSION);
    width_ = width;
    height_ = height;
    std::string log;
    if (!linkProgram(gl, &program_, &log)) {
        *reason = std::string(name) + ": " + log;
        return false;
    }
    const auto loc = [&](const char* u) { return gl.GetUniformLocation(program_, u); };
    uCamPos_ = loc("camPos_m"), uRight_ = loc("camRight"), uUp_ = loc("camUp");
    uFwd_ = loc("camFwd"), uScale_ = loc("clipScale"), uNear_ = loc("near_m");
    uFirstId_ = loc("firstId1");

    // Framebuffer: ids (R32UI), depth (32-bit float).
    const auto renderbuffer = [&](GLenum format, GLenum attachment) {
        GLuint rb = 0;
        gl.GenRenderbuffers(1, &rb);
        gl.BindRenderbuffer(GL_RENDERBUFFER, rb);
        gl.RenderbufferStorage(GL_RENDERBUFFER, format, width, height);
        gl.FramebufferRenderbuffer(GL_FRAMEBUFFER, attachment, GL_RENDERBUFFER, rb);
        return rb;
    };
    gl.GenFramebuffers(1, &fbo_);
    gl.BindFramebuffer(GL_FRAMEBUFFER, fbo_);
    colorIds_ = renderbuffer(GL_R32UI, GL_COLOR_ATTACHMENT0);
    depth_ = renderbuffer(GL_DEPTH_COMPONENT32F, GL_DEPTH_ATTACHMENT);
    const GLenum bufs[1] = {GL_COLOR_ATTACHMENT0};
    gl.DrawBuffers(1, bufs);
    gl.ReadBuffer(GL_COLOR_ATTACHMENT0);
    if (gl.CheckFramebufferStatus(GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE) {
        *reason = std::string(name) + ": R32UI + depth32F framebuffer incomplete";
        return false;
    }
    // Fixed state: reversed Z, both faces, scissored to the rectangle asked for.
    gl.ClipControl(GL_LOWER_LEFT, GL_ZERO_TO_ONE);
    gl.Enable(GL_DEPTH_TEST);
    gl.DepthFunc(GL_GREATER);
    gl.Disable(GL_CULL_FACE);
    gl.Enable(GL_SCISSOR_TEST);
    gl.Viewport(0, 0, width, height);
    gl.UseProgram(program_);
    gl.PixelStorei(GL_PACK_ALIGNMENT, 4);
    gl.PixelStorei(GL_PACK_ROW_LENGTH, width);
    if (gl.GetError() != GL_NO_ERROR) {
        *reason = std::string(name) + ": GL error while setting up the pass";
        return false;
    }
    const std::size_t np = static_cast<std::size_t>(width) * static_cast<std::size_t>(height);
    ids_.assign(np, 0u);
    ctx_->release();
    return true;
}

GlVisibility::~GlVisibility() {
    if (!ctx_ || !gl_ || !gl_->DeleteBuffers || !ctx_->makeCurrent()) return;
    const Gl& gl = *gl_;
    for (Mesh& m : meshes_) {
        gl.DeleteBuffers(1, &m.vbo);
        gl.DeleteVertexArrays(1, &m.vao);
    }
    const GLuint rbs[2] = {colorIds_, depth_};
    gl.DeleteRenderbuffers(2, rbs);
    gl.DeleteFramebuffers(1, &fbo_);
    if (program_) gl.DeleteProgram(program_);
    ctx_->release();
}

int GlVisibility::addMesh(const float* vertices_m, std::size_t vertexCount,
                          const std::uint32_t* indices, std::size_t triangleCount,
                          std::uint32_t geomId) {
    if (geomId >= kGlMiss - 1) throw SetupError("GL visibility: geometry id out of range");
    // Ids + 1 must stay below 2³²: the words are 32-bit and 0 is a miss.
    if (triangleCount >= std::size_t{0xFFFFFFFFu} - nextId_) {
        throw SetupError("GL visibility: more than 2^32 - 2 triangles in all");
    }
    for (std::size_t i = 0; i < 3 * triangleCount; ++i) {
        if (indices[i] >= vertexCount) throw SetupError("GL visibility: vertex index out of range");
    }
    if (!ctx_->makeCurrent()) throw SetupError("GL visibility: cannot make the context current");
    const Gl& gl = *gl_;
    Mesh m;
    m.indices.assign(indices, indices + 3 * triangleCount);
    m.vertices_m.assign(vertices_m, vertices_m + 3 * vertexCount);
    m.firstId = nextId_;
    m.geomId = geomId;
    nextId_ += static_cast<std::uint32_t>(triangleCount);
    gl.GenVertexArrays(1, &m.vao);
    gl.BindVertexArray(m.vao);
    gl.GenBuffers(1, &m.vbo);
    gl.BindBuffer(GL_ARRAY_BUFFER, m.vbo);
    gl.BufferData(GL_ARRAY_BUFFER, static_cast<GLsizeiptr>(9 * triangleCount * sizeof(float)),
                  nullptr, GL_DYNAMIC_DRAW);
    gl.VertexAttribPointer(0, 3, GL_FLOAT, GL_FALSE, 3 * sizeof(float), nullptr);
    gl.EnableVertexAttribArray(0);
    gl.BindVertexArray(0);
    if (staging_.size() < 9 * triangleCount) staging_.resize(9 * triangleCount);
    meshes_.push_back(std::move(m));
    const int handle = static_cast<int>(meshes_.size()) - 1;
    if (setVertices(handle, vertices_m) != GlStatus::kOk) {
        throw SetupError("GL visibility: cannot upload a mesh");
    }
    ctx_->release();
    return handle;
}

// The triangle list de-indexed (three vertices of their own per triangle), so that a vertex's
// corner in its triangle is gl_VertexID mod 3 and gl_PrimitiveID the triangle's index.
GlStatus GlVisibility::setVertices(int mesh, const float* vertices_m) noexcept {
    if (mesh < 0 || static_cast<std::size_t>(mesh) >= meshes_.size()) return GlStatus::kBadRect;
    if (!ctx_->makeCurrent()) return GlStatus::kNotCurrent;
    Mesh& m = meshes_[static_cast<std::size_t>(mesh)];
    if (vertices_m != m.vertices_m.data()) {
        std::copy(vertices_m, vertices_m + m.vertices_m.size(), m.vertices_m.begin());
    }
    const std::size_t n = m.indices.size();
    for (std::size_t k = 0; k < n; ++k) {
        const float* v = vertices_m + 3 * static_cast<std::size_t>(m.indices[k]);
        staging_[3 * k] = v[0];
        staging_[3 * k + 1] = v[1];
        staging_[3 * k + 2] = v[2];
    }
    const Gl& gl = *gl_;
    gl.BindBuffer(GL_ARRAY_BUFFER, m.vbo);
    gl.BufferSubData(GL_ARRAY_BUFFER, 0, static_cast<GLsizeiptr>(3 * n * sizeof(float)),
                     staging_.data());
    return GlStatus::kOk;
}

void GlVisibility::setEnabled(int mesh, bool enabled) noexcept {
    if (mesh >= 0 && static_cast<std::size_t>(mesh) < meshes_.size()) {
        meshes_[static_cast<std::size_t>(mesh)].enabled = enabled;
    }
}

GlStatus GlVisibility::render(const GlView& view, int x0, int y0, int x1, int y1) noexcept {
    if (x0 < 0 || y0 < 0 || x1 > width_ || y1 > height_ || view.width != width_ ||
        view.height != height_) {
        return GlStatus::kBadRect;
    }
    if (x1 <= x0 || y1 <= y0) return GlStatus::kOk;
    if (!ctx_->makeCurrent()) return GlStatus::kNotCurrent;
    const auto start = std::chrono::steady_clock::now();
    const Gl& gl = *gl_;
    const auto f = [](double a) { return static_cast<float>(a); };
    const auto u3 = [&](int loc, const Vec3& a) { gl.Uniform3f(loc, f(a.x), f(a.y), f(a.z)); };
    u3(uCamPos_, view.position_m);
    u3(uRight_, view.right);
    u3(uUp_, view.up);
    u3(uFwd_, view.forward);
    gl.Uniform2f(uScale_, f(2.0 * view.focalLength_m / (view.pitchX_m * width_)),
                 f(2.0 * view.focalLength_m / (view.pitchY_m * height_)));
    gl.Uniform1f(uNear_, f(kNear_m));
    gl.Scissor(x0, y0, x1 - x0, y1 - y0);
    const GLuint zeroIds[4] = {0, 0, 0, 0};
    const GLfloat farDepth[1] = {0.0f};
    gl.ClearBufferuiv(GL_COLOR, 0, zeroIds);
    gl.ClearBufferfv(GL_DEPTH, 0, farDepth);
    for (const Mesh& m : meshes_) {
        if (!m.enabled || m.indices.empty()) continue;
        gl.Uniform1ui(uFirstId_, m.firstId + 1u);
        gl.BindVertexArray(m.vao);
        gl.DrawArrays(GL_TRIANGLES, 0, static_cast<GLsizei>(m.indices.size()));
    }
    gl.BindVertexArray(0);
    // Read back the rectangle in place (GL_PACK_ROW_LENGTH = width).
    const std::size_t at = static_cast<std::size_t>(y0) * width_ + static_cast<std::size_t>(x0);
    gl.ReadPixels(x0, y0, x1 - x0, y1 - y0, GL_RED_INTEGER, GL_UNSIGNED_INT, &ids_[at]);
    lastView_ = view;
    const GlStatus st = gl.GetError() == GL_NO_ERROR ? GlStatus::kOk : GlStatus::kGlError;
    lastRender_ms_ =
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count();
    return st;
}

const GlVisibility::Mesh* GlVisibility::meshOf(std::uint32_t word) const noexcept {
    if (word == 0 || word > nextId_) return nullptr;
    // The last mesh whose first id is ≤ word − 1 (meshes_ is in id order; an empty mesh shares
    // its first id with the next).
    const auto m = std::upper_bound(meshes_.begin(), meshes_.end(), word - 1u,
                                    [](std::uint32_t v, const Mesh& e) { return v < e.firstId; });
    return m == meshes_.begin() ? nullptr : &*(m - 1);
}

GlVisibility::IdRange GlVisibility::idRange(std::uint32_t word) const noexcept {
    const Mesh* mesh = meshOf(word);
    if (mesh == nullptr) return {};
    return {mesh->firstId, static_cast<std::uint32_t>(mesh->indices.size() / 3), mesh->geomId};
}

GlHit GlVisibility::hit(int x, int y) const noexcept {
    GlHit h;
    const std::size_t i = static_cast<std::size_t>(y) * width_ + static_cast<std::size_t>(x);
    const Mesh* mesh = meshOf(ids_[i]);
    if (mesh == nullptr) return h;
    const std::uint32_t prim = ids_[i] - 1u - mesh->firstId;
    const auto vertex = [&](std::uint32_t k) {
        const float* p =
            &mesh->vertices_m[3 * static_cast<std::size_t>(mesh->indices[3 * prim + k])];
        return Vec3{p[0], p[1], p[2]};
    };
    // The pixel-centre ray as the renderer casts it (Renderer::Impl::pixelDir).
    const GlView& v = lastView_;
    const Vec3 d =
        normalized(v.forward * v.focalLength_m + v.right * ((x + 0.5 - 0.5 * width_) * v.pitchX_m) -
                   v.up * ((y + 0.5 - 0.5 * height_) * v.pitchY_m));
    double t = 0.0, u = 0.0, w = 0.0;
    if (!rayPlaneOfTriangle(v.position_m, d, vertex(0), vertex(1), vertex(2), &t, &u, &w)) return h;
    h.geomId = mesh->geomId;
    h.primId = prim;
    h.u = u;
    h.v = w;
    h.t_m = t;
    return h;
}

}  // namespace nvs::render
