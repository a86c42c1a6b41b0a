#pragma once
// The night-scene renderer (docs/design.md §4.4): Embree 3 ray casting of a scene::Scene into a
// photoelectron radiance image Lpe [pe s⁻¹ m⁻² sr⁻¹] and a band radiance image
// Lβ = ∫ L(λ) β(λ) dλ [W m⁻² sr⁻¹] (β the camera's relative response, the thesis's unit).
//
// Per pixel (docs/render.md has the derivations):
//   primary hit P with normal n (facing the camera) and material m (ρ, specularity s);
//   L = (1−s)/π · [ ρ☾ E☾ cos θ☾ V☾                                    Moon, shadow ray
//                 + Σ_lamps ∫I_l ρ w dλ · cos θ_r / r² · V_l           inverse square, cosine
//                 + F_sky (ρ☾ E_sky☾ + ρ_n E_night) ]                   sky-view factor
//     + s ρ☾ L(reflected ray)                                          one specular bounce
// where ρ_src = ∫S_src ρ w dλ / ∫S_src w dλ are the (source, material) band coefficients,
// precomputed at setup from the source spectra, and E☾ = E_toa · T(z) comes from the
// atmosphere table each frame. Rays that miss see the sky radiance (lunar sky scattering and
// night sky); the Moon's disk and the lamps are drawn with their own radiance.
//
// Coarse radiance tiles: with `coarseFactor` f > 1, primary rays stay at full resolution (the
// geometry: edges, materials, normals) while the direct light (shadow rays, lamp geometry,
// specular bounce) is computed on a grid every f pixels and interpolated to each pixel with
// bilinear weights restricted to samples on the same surface (same object, normal within 18°,
// within a plane tolerance); pixels with no such sample are computed at full rate.
//
// Threading: sim/ starts no threads. render() hands row ranges to a RowExecutor, which may
// run them concurrently. Per frame nothing is allocated and nothing throws.

#include <array>
#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sim/core/image.h"
#include "sim/core/row_executor.h"
#include "sim/core/spectrum.h"
#include "sim/msg/sky.h"
#include "sim/scene/scene.h"

namespace nvs::render {

// The bands and the frame's sky come as messages (sim/msg/sky.h, filled by sim/sky): the
// renderer knows nothing of the ephemeris or the atmosphere model.
using msg::BandValues;
using msg::FrameSky;
using msg::FrameStar;
using msg::kBandPe;  // photoelectron radiance, weight QE(λ) λ/(hc)
using msg::kBands;
using msg::kBandW;  // band radiance, weight β(λ)
using msg::kMaxStars;

// Terms of the radiance (Renderer::setTerms), for diagnostics and tests: a render with only
// kTermMoon shows where the Moon's direct light reaches (its shadows are exact zeros).
inline constexpr unsigned kTermMoon = 1u;      // Moon direct, shadow ray
inline constexpr unsigned kTermLamps = 2u;     // lamp direct, shadow rays
inline constexpr unsigned kTermSky = 4u;       // sky-view factor × sky irradiance
inline constexpr unsigned kTermSpecular = 8u;  // one specular bounce
inline constexpr unsigned kTermInView = 16u;   // sky, Moon disk, lamps and stars seen directly
inline constexpr unsigned kTermAll = 31u;

struct PinholeCamera {
    int width = 768;
    int height = 494;
    double focalLength_m = 0.036;
    double pitchX_m = 11e-6 * 1.636;  // pixel pitch in the focal (photocathode) plane
    double pitchY_m = 13e-6 * 1.636;
};

// How the primary rays' hits (the geometry buffer) are found (docs/render.md, "Primary
// visibility"): Embree's coherent packets; OpenGL rasterisation (sim/render/gl_visibility.h:
// a GPU through EGL, else Mesa's llvmpipe through EGL or OSMesa); or whichever of the two is
// present and faster on the first view (measured once: choosePrimaryVisibility).
enum class PrimaryVisibility { kEmbree, kGl, kAuto };
const char* primaryVisibilityName(PrimaryVisibility v) noexcept;  // "embree", "gl", "auto"
// Parses "embree", "gl" or "auto"; false otherwise.
bool parsePrimaryVisibility(const std::string& s, PrimaryVisibility* v) noexcept;

struct RenderConfig {
    PinholeCamera camera;
    std::array<Spectrum, kBands> bandWeight;  // w_pe = QE λ/(hc), w_W = β
    Spectrum moonShape;                       // relative TOA spectrum of moonlight
    Spectrum nightSkyShape;                   // relative spectrum of the night sky
    int coarseFactor = 1;                     // 1 = full rate
    int skyViewRays = 64;                     // per surface element, at setup
    int lampShadowRays = 1;                   // per lamp with an aperture, per point
    bool specular = true;
    PrimaryVisibility primaryVisibility = PrimaryVisibility::kEmbree;
    // Embree's kernel set: "" for Embree's choice (the best the CPU has), else a pin
    // (sim/core/cpu_isa.h: sse2, sse4.2, avx, avx2, avx512; the runtime reads NVS_EMBREE_ISA).
    std::string embreeIsa;
};

// The row executors live in sim/core (the camera chain uses them too).
using RowExecutor = nvs::RowExecutor;
using SerialExecutor = nvs::SerialExecutor;

// The thermal band (docs/thermal.md, "Rendering"). The scene's surfaces are grouped into classes
// by material, orientation (5 tilt bands, 4 azimuth quadrants for the inclined ones) and sky-view
// factor (4 bands), each face of a triangle on its own; the composition root solves each class's
// heat balance and hands the frame its temperatures.
inline constexpr int kThermalCosBins = 11;  // ε(cos θ) at cos θ = i/10

struct ThermalSurface {
    int material = 0;  // scene material index
    int key = 0;       // (material, tilt band, azimuth quadrant, sky-view band)
    Vec3 normal{0.0, 0.0, 1.0};
    double tilt_rad = 0.0;     // mean normal from the zenith
    double azimuth_rad = 0.0;  // from north through east
    double skyView = 1.0;      // mean sky-view factor
    double area_m2 = 0.0;
    std::vector<Vec3> samples_m;  // points on the class (world, objects at t = 0): Sun shadows
};

// One thermal frame's inputs (tables the composition root fills from sim/thermal and
// sim/lwir; no allocation per frame). Radiances are band radiances [W m⁻² sr⁻¹].
struct ThermalFrame {
    const float* surfaceTemperature_K = nullptr;  // per ThermalSurface
    const float* emissivity = nullptr;            // per ThermalSurface × kThermalCosBins
    const float* blackbody = nullptr;             // B(T) at T = blackbodyT0_K + i·step
    double blackbodyT0_K = 150.0, blackbodyStep_K = 0.1;
    int blackbodyCount = 0;
    const float* pathTau = nullptr;  // τ(r) and L_path(r) at ln r = lnRange0 + i·step
    const float* pathRadiance = nullptr;
    double lnRange0 = 0.0, lnRangeStep = 0.1;
    int rangeCount = 0;
    const float* skyRadiance = nullptr;  // at view zenith i·90°/(skyCount − 1)
    int skyCount = 0;
    double skyDiffuse = 0.0;  // the sky's radiance averaged for a diffuse reflector
    // What a surface sees besides the sky: the ground around it (the composition root's
    // area-weighted band radiance of the open ground's classes).
    double groundRadiance = 0.0;
};

struct RenderStats {
    std::uint64_t primaryRays = 0;
    std::uint64_t shadowRays = 0;
    std::uint64_t secondaryRays = 0;
    std::uint64_t total() const { return primaryRays + shadowRays + secondaryRays; }
};

class Renderer {
  public:
    // Setup: builds the Embree scene, the per-(source, material) coefficients and the
    // sky-view factors. Throws SetupError.
    Renderer(const scene::Scene& scene, const RenderConfig& config);
    ~Renderer();
    Renderer(const Renderer&) = delete;
    Renderer& operator=(const Renderer&) = delete;

    // Per frame (no allocation by nvstim, no throw). Moves moving objects to their pose at t_s.
    void setTime(double t_s) noexcept;
    void setCamera(const scene::CameraPose& pose) noexcept;
    void setLampOn(int lamp, bool on) noexcept { lampOn_[static_cast<std::size_t>(lamp)] = on; }
    void setCoarseFactor(int f) noexcept;                       // ≤ the factor given at setup
    void setTerms(unsigned terms) noexcept { terms_ = terms; }  // kTerm* mask; kTermAll
    // Takes an object out of the scene (primary and shadow rays pass through it) or puts it
    // back (for tests of what an object's shadow is). Recommits the Embree scene.
    void setObjectEnabled(int object, bool enabled) noexcept;
    // Renders both bands. Images must be camera.width × camera.height. With rowParity 0 or 1
    // (full-rate lighting only; ignored with coarse tiles) only the rows y with y mod 2 =
    // rowParity are written, and only their primary rays are cast when the camera moved: an
    // interlaced field's own rows. The other rows keep what the images held.
    void render(const FrameSky& sky, ImageView<float> pe, ImageView<float> bandW, RowExecutor& exec,
                int rowParity = -1) noexcept;

    const RenderStats& lastStats() const { return stats_; }
    const PinholeCamera& camera() const { return config_.camera; }
    // The camera's pose in the scene frame (ENU metres) as last set: its centre and unit axes,
    // right and up in the image plane and forward along the optical axis.
    void cameraAxes(Vec3* position_m, Vec3* right, Vec3* up, Vec3* forward) const noexcept;
    // A tracked object's ground truth in the current pose (truthBoxes).
    struct ObjectTruth {
        int id = 0;
        const char* cls = "";  // the scene object's class (scene key `class`; default its name)
        float x_px = 0.0f, y_px = 0.0f, w_px = 0.0f, h_px = 0.0f;  // its box, clipped to the image
        // The fraction of its projected area in the image that the camera sees, not hidden by
        // other objects: each triangle sampled at the centroids of an n × n subdivision
        // (n from its size in the image, 1 … 6), a ray from the camera to each sample, which is
        // seen when the ray's first hit is this object; weighted by the sample's projected
        // solid angle (area·|cos|/d²). 0 when no sample lies in the image.
        float visible = 0.0f;
        float range_m = 0.0f;    // camera to the centroid of its vertices
        bool truncated = false;  // its projection crosses the image's edge or the camera plane
    };
    // Truth of the tracked objects in the current pose (objects wholly outside the image or
    // behind the camera are left out). Returns the count written (≤ maxBoxes). Ray casts, no
    // allocation.
    int truthBoxes(ObjectTruth* out, int maxBoxes) const noexcept;

    // Thermal band. Setup: groups the scene's faces into classes (at most `maxSamples` sample
    // points each) and keeps the pixel → class map; returns the classes.
    const std::vector<ThermalSurface>& prepareThermal(int maxSamples = 32);
    // Setup: the share of a class's sample points that see the direction `towardSun` (unit,
    // world), by shadow rays through the scene as placed now.
    double sunlitFraction(const ThermalSurface& surface, const Vec3& towardSun) const;
    // Setup (after prepareThermal, which sets the renderer's own camera): the camera the thermal
    // band is drawn for. A thermal camera boresighted with this renderer's (the same centre of
    // projection and axes, its own pinhole) shares the primary hits: each of its pixels takes
    // the hit of the G-buffer pixel that holds its centre (nearest sample; docs/thermal.md,
    // "Shared primary hits"), and casts a ray of its own where it lies outside this camera's
    // image. Throws SetupError on a view without size, focal length or pitch.
    void setThermalView(const PinholeCamera& view);
    const PinholeCamera& thermalView() const noexcept;
    int thermalOwnRays() const noexcept;  // view pixels outside this camera's image
    // Per frame (after prepareThermal): the band radiance at the aperture of the thermal view
    // (`radiance` its size),
    //   L = τ(r)·(ε(θ)·B(T) + (1 − ε(θ))·L_env) + L_path(r),
    // L_env = s·L_mirror + (1 − s)·(F·L_sky,diffuse + (1 − F)·L_ground) (s the material's
    // specularity, F the sky-view factor); rays that miss see the sky radiance at their zenith
    // angle (L_ground below the horizon). Shares the G-buffer with render(): a render() of the
    // same pose before it leaves no primary ray to cast but the view's own.
    void renderThermal(const ThermalFrame& frame, ImageView<float> radiance,
                       RowExecutor& exec) noexcept;
    // The thermal class of a view pixel's primary hit (−1: sky), after renderThermal.
    int thermalClassOfPixel(int x, int y) const noexcept;
    // The surface temperature renderThermal gives a pixel's hit (its class's, interpolated in
    // sky view between neighbouring classes); 0 for the sky.
    double thermalPixelTemperature_K(const ThermalFrame& frame, int x, int y) const noexcept;

    // Introspection for tests.
    // The primary hit of a pixel: false on a miss.
    bool pixelHit(int x, int y, Vec3* position_m, int* material, int* object) const noexcept;
    // Sky-view factor at a point of a triangle (interpolated), front or back side.
    double skyViewFactor(int object, int triangle, double u, double v, bool back) const;
    // Coefficient ∫ I_l ρ_m w_b dλ / π (for a lamp without aperture) or ∫ L_glass ρ w / π.
    double lampCoefficient(int lamp, int material, int band) const;
    double moonCoefficient(int material, int band) const { return rhoMoon_[idx(material, band)]; }
    // Surface normal (facing the camera) and sky-view factor of a pixel's primary hit.
    bool pixelSurface(int x, int y, Vec3* normal, double* skyViewFactor) const noexcept;

    // Primary visibility. Whether the OpenGL pass makes the geometry buffer now (else Embree).
    bool primaryByGl() const noexcept;
    // With PrimaryVisibility::kAuto, times both passes on the current view with exec (setup:
    // the first render does it if no one has) and keeps the faster. Returns the note below.
    std::string choosePrimaryVisibility(RowExecutor& exec);
    // One line: the path in use and why (OpenGL backend and renderer, the times measured, or
    // why OpenGL is not available), e.g. for a log line.
    std::string primaryVisibilityNote() const;
    // Wall time of one primary pass over the whole image on the current view [ms], each path,
    // the mean of `repetitions` after one untimed pass; gl_ms < 0 without an OpenGL pass. The GL
    // time includes drawing and reading back. The G-buffer is rebuilt at the next render.
    // Wall times of one primary pass [ms]; glRender_ms is the GL pass's draw and read-back,
    // the rest of gl_ms the G-buffer built from its hits. -1: not measured.
    struct PrimaryTiming {
        double embree_ms = -1.0, gl_ms = -1.0, glRender_ms = -1.0;
    };
    enum class PrimaryPaths { kBoth, kEmbree, kGl };
    PrimaryTiming measurePrimaryPasses(RowExecutor& exec, int repetitions,
                                       PrimaryPaths paths = PrimaryPaths::kBoth);
    // Embree alone, for the benchmarks (rt/bench times it): one pass of primary rays through
    // every pixel centre of the current view, as single rays (rtcIntersect1) or as coherent
    // 16-ray packets (rtcIntersect16, as the renderer casts them). Writes nothing; returns the
    // number of hits.
    std::uint64_t tracePrimaryRays(bool packets) const noexcept;

    struct Impl;

  private:
    static std::size_t idx(int m, int b) { return static_cast<std::size_t>(m) * kBands + b; }
    RenderConfig config_;
    std::unique_ptr<Impl> impl_;
    std::vector<double> rhoMoon_, rhoNight_;  // [m][b]
    std::vector<bool> lampOn_;
    RenderStats stats_;
    int coarse_ = 1;
    unsigned terms_ = kTermAll;
};

}  // namespace nvs::render
