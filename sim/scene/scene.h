#pragma once
// A night scene as data (docs/design.md §4.4): materials with spectral reflectance and specularity,
// triangle meshes placed in the scene frame, lamps, moving objects with trajectories, and the
// camera's pose. Loaded from a TOML file that names OBJ meshes and reflectance CSVs; every error
// names the file and line it comes from (docs/scene.md has the format).
//
// Frame: the scene frame is east-north-up (ENU) at the site, in metres, so the Moon's azimuth
// and altitude from sim/astro give its direction in this frame without any other rotation.

#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

#include "sim/core/error.h"
#include "sim/core/geometry.h"
#include "sim/core/spectrum.h"
#include "sim/core/units.h"

namespace nvs::scene {

struct Material {
    std::string name;
    Spectrum reflectance;      // total hemispherical reflectance ρ(λ), 0..1
    double specularity = 0.0;  // fraction of ρ reflected as a mirror (DIRSIG's SPECULARITY)
    std::string source;        // provenance of the reflectance ("# source:" of its CSV)
    FileLoc loc;
    // The thermal material it is made of (a name in the thermal material library); empty:
    // none given (a thermal scenario then fails at its place).
    std::string thermal;
    FileLoc thermalLoc;
};

// A triangle mesh in its own (object) frame, metres. One material index per triangle.
struct Mesh {
    std::vector<float> vertices_m;         // x, y, z per vertex
    std::vector<std::uint32_t> triangles;  // 3 vertex indices per triangle
    std::vector<std::uint16_t> materials;  // material index per triangle
    std::size_t vertexCount() const { return vertices_m.size() / 3; }
    std::size_t triangleCount() const { return triangles.size() / 3; }
};

// A pose keyframe of a moving object: position and heading (yaw from north through east).
struct Keyframe {
    double t_s = 0.0;  // seconds since the scenario start
    Vec3 position_m;
    double yaw_rad = 0.0;
};

struct Object {
    std::string name;
    Mesh mesh;
    // Placement: sceneFromObject = translate(position) · rotZ(−yaw) (yaw turns +y toward +x).
    Vec3 position_m;
    double yaw_rad = 0.0;
    std::vector<Keyframe> trajectory;  // empty: static
    int trackId = -1;                  // ≥ 0: reported as a truth box
    std::string truthClass;            // its truth box's class (key `class`; default: name)
    FileLoc loc;

    bool moving() const { return !trajectory.empty(); }
    // Pose at time t (keyframes interpolated linearly, held beyond the ends). No allocation.
    void poseAt(double t_s, Vec3* position_m_out, double* yaw_rad_out) const noexcept;
};

// A lamp (docs/design.md §4.2): a tungsten filament (Planck at its colour temperature) inside a
// diffusing glass bulb, optionally in a housing with a circular aperture.
//   bare bulb:     point source of spectral intensity I(λ) = L_bb(λ, T) · A_proj, limited to a
//                  cone of half-angle `cutoff` about `axis` (the housing's field of view)
//   with aperture: the bulb's glass is a Lambertian diffuser of radiance
//                  L_glass = τ Φ/(4π r_b²)/π = τ I/(π r_b²), seen through the aperture disk;
//                  the disk is an extended source of that radiance, sampled over its area.
struct Lamp {
    std::string name;
    Vec3 position_m;            // filament centre / aperture centre
    Vec3 axis{0.0, 0.0, -1.0};  // housing axis (aperture normal), unit
    double temperature_K = 2856.0;
    double projectedArea_m2 = 0.0;  // filament's mean projected area
    double glassTransmission = 1.0;
    double bulbRadius_m = 0.03;
    double cutoff_rad = kPi;          // half-angle; π = unhoused
    double apertureDiameter_m = 0.0;  // 0 = no aperture
    int apertureSamples = 16;
    bool on = true;
    // ≥ 0: the lamp rides on this object (a vehicle's headlamp): position_m and axis are given
    // in the object's frame and follow its pose (placeAt).
    int attachObject = -1;
    FileLoc loc;

    // Where the lamp is and where its axis points at time t (world): position_m and axis as
    // given, or carried by the pose of `attached` (the object named by attachObject; the same
    // rotation as the object's vertices). No allocation.
    void placeAt(const Object* attached, double t_s, Vec3* position_out,
                 Vec3* axis_out) const noexcept;

    // Spectral intensity of the bare filament [W sr⁻¹ nm⁻¹] (sim/core/planck.h).
    Spectrum spectralIntensity_W_sr_nm() const;
    // Radiance of the bulb glass [W m⁻² sr⁻¹ nm⁻¹] (what the camera sees when it looks at it).
    Spectrum glassRadiance_W_m2_sr_nm() const;
    bool hasAperture() const { return apertureDiameter_m > 0.0; }
};

struct CameraPose {
    Vec3 position_m;
    Vec3 target_m{0.0, 1.0, 0.0};
    Vec3 up{0.0, 0.0, 1.0};
    double twist_rad = 0.0;
};

// A pose's unit axes: forward (to the target), image right and image up, `up` made orthogonal
// and the image turned by the twist about the line of sight (the renderer's camera, and the
// geometry a rig publishes, rt/compose/rig.h).
void cameraAxes(const CameraPose& p, Vec3* forward, Vec3* right, Vec3* up) noexcept;

struct Scene {
    std::filesystem::path file;
    std::vector<Material> materials;
    std::vector<Object> objects;
    std::vector<Lamp> lamps;
    CameraPose camera;

    int materialIndex(const std::string& name) const;  // −1 if absent
    int lampIndex(const std::string& name) const;      // −1 if absent
    std::size_t triangleCount() const;
    // Throws SetupError if the scene cannot be rendered (no triangles, bad indices, NaN).
    void validate() const;
};

// Loads a scene TOML file (docs/scene.md). Throws SetupError naming file:line.
Scene loadScene(const std::filesystem::path& path);

// Loads an OBJ mesh. Each group/object name (`g` or `o`, the thesis's AutoCAD layers) is mapped
// to a material through `layerMaterial` (layer name → material index); faces outside any group
// or in an unmapped group get `defaultMaterial` (−1: an error naming the line). Non-finite
// vertices are errors naming their line. Polygons are fan-triangulated.
Mesh loadObjMesh(const std::filesystem::path& path,
                 const std::vector<std::pair<std::string, int>>& layerMaterial, int defaultMaterial,
                 const FileLoc& referencedFrom);
// The same from the text of an OBJ file; `name` names it in errors. loadObjMesh reads a
// regular file of at most 512 MiB (sim/core/input_file.h).
Mesh parseObjMesh(const std::string& text, const std::string& name,
                  const std::vector<std::pair<std::string, int>>& layerMaterial,
                  int defaultMaterial);

// A flat reflectance curve (grey), for tests and materials given by one number.
Spectrum greyReflectance(double rho);

}  // namespace nvs::scene
