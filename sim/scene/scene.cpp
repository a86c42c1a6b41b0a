#include "sim/scene/scene.h"

#include <tiny_obj_loader.h>

#include <algorithm>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <limits>
#include <sstream>

#include "sim/core/config.h"
#include "sim/core/input_file.h"
#include "sim/core/planck.h"
#include "sim/core/units.h"

namespace nvs::scene {

namespace {

constexpr double kDeg = kPi / 180.0;

Vec3 vec3At(const ConfigTable& t, std::string_view key, const Vec3& fallback, bool required) {
    if (!t.contains(key)) {
        if (required) t.fail(key, "is required (an array [x, y, z])");
        return fallback;
    }
    const auto v = t.require<std::vector<double>>(key);
    if (v.size() != 3) t.fail(key, "must have 3 numbers, found " + std::to_string(v.size()));
    for (double c : v) {
        if (!std::isfinite(c)) t.fail(key, "must be finite");
    }
    return {v[0], v[1], v[2]};
}

double positive(const ConfigTable& t, std::string_view key, double fallback) {
    const double v = t.get<double>(key, fallback);
    if (!(v > 0.0) || !std::isfinite(v)) t.fail(key, "must be a positive number");
    return v;
}

// Calls f(line, lineNo) for every line of text (1-based), without the '\r' of a CRLF.
template <typename F>
void forEachLine(std::string_view text, F f) {
    int lineNo = 0;
    for (std::size_t pos = 0; pos < text.size();) {
        const std::size_t eol = std::min(text.find('\n', pos), text.size());
        std::string_view line = text.substr(pos, eol - pos);
        pos = eol + 1;
        if (!line.empty() && line.back() == '\r') line.remove_suffix(1);
        if (!f(line, ++lineNo)) return;
    }
}

// Line (1-based) of the n-th (0-based) line starting with `prefix`; 0 if absent.
int nthLineStartingWith(std::string_view text, std::string_view prefix, std::size_t n) {
    int found = 0;
    std::size_t seen = 0;
    forEachLine(text, [&](std::string_view line, int lineNo) {
        const auto first = line.find_first_not_of(" \t");
        if (first == std::string_view::npos || line.substr(first, prefix.size()) != prefix)
            return true;
        if (seen++ == n) found = lineNo;
        return found == 0;
    });
    return found;
}

// Line of the `g NAME` or `o NAME` statement that opens a group.
int groupLine(std::string_view text, const std::string& name) {
    int found = 0;
    forEachLine(text, [&](std::string_view line, int lineNo) {
        const auto b = line.find_first_not_of(" \t");
        if (b == std::string_view::npos || b + 1 >= line.size() ||
            (line[b] != 'g' && line[b] != 'o') || (line[b + 1] != ' ' && line[b + 1] != '\t'))
            return true;
        std::string_view rest = line.substr(b + 2);
        const auto rb = rest.find_first_not_of(" \t");
        const auto re = rest.find_last_not_of(" \t");
        if (rb != std::string_view::npos && rest.substr(rb, re - rb + 1) == name) found = lineNo;
        return found == 0;
    });
    return found;
}

// tinyobjloader reads "nan" and garbage as numbers without complaint; every vertex statement
// is checked first so that a bad one is reported with its line.
void checkVertexLines(std::string_view text, const std::string& name) {
    forEachLine(text, [&](std::string_view line, int lineNo) {
        if (line.size() < 2 || line[0] != 'v' || (line[1] != ' ' && line[1] != '\t')) return true;
        std::istringstream ss{std::string(line.substr(2))};
        std::string tok;
        int count = 0;
        while (count < 3 && ss >> tok) {
            char* end = nullptr;
            const double v = std::strtod(tok.c_str(), &end);
            if (end == tok.c_str() || *end != '\0' || !std::isfinite(v)) {
                throw SetupError(FileLoc{name, lineNo}, "vertex coordinate '" + tok.substr(0, 40) +
                                                            "' is not a finite number");
            }
            ++count;
        }
        if (count < 3) throw SetupError(FileLoc{name, lineNo}, "vertex needs 3 coordinates");
        return true;
    });
}

}  // namespace

Spectrum greyReflectance(double rho) {
    return Spectrum(rho);
}

void Lamp::placeAt(const Object* attached, double t_s, Vec3* position_out,
                   Vec3* axis_out) const noexcept {
    if (attached == nullptr) {
        *position_out = position_m;
        *axis_out = axis;
        return;
    }
    Vec3 pos;
    double yaw = 0.0;
    attached->poseAt(t_s, &pos, &yaw);
    // Yaw turns the object's +y toward +x (east), as its vertices: x' = x cos + y sin.
    const double c = std::cos(yaw), sn = std::sin(yaw);
    const auto turn = [&](const Vec3& v) {
        return Vec3{v.x * c + v.y * sn, -v.x * sn + v.y * c, v.z};
    };
    *position_out = pos + turn(position_m);
    *axis_out = turn(axis);
}

void Object::poseAt(double t_s, Vec3* position_out, double* yaw_out) const noexcept {
    if (trajectory.empty()) {
        *position_out = position_m;
        *yaw_out = yaw_rad;
        return;
    }
    if (t_s <= trajectory.front().t_s) {
        *position_out = trajectory.front().position_m;
        *yaw_out = trajectory.front().yaw_rad;
        return;
    }
    if (t_s >= trajectory.back().t_s) {
        *position_out = trajectory.back().position_m;
        *yaw_out = trajectory.back().yaw_rad;
        return;
    }
    std::size_t i = 1;
    while (trajectory[i].t_s < t_s)
        ++i;
    const Keyframe& a = trajectory[i - 1];
    const Keyframe& b = trajectory[i];
    const double f = (t_s - a.t_s) / (b.t_s - a.t_s);
    *position_out = a.position_m + (b.position_m - a.position_m) * f;
    // Heading along the shorter arc.
    double d = std::remainder(b.yaw_rad - a.yaw_rad, 2.0 * kPi);
    *yaw_out = a.yaw_rad + d * f;
}

Spectrum Lamp::spectralIntensity_W_sr_nm() const {
    return planckRadiance_W_m2_sr_nm(temperature_K) * projectedArea_m2;
}

Spectrum Lamp::glassRadiance_W_m2_sr_nm() const {
    // The filament's flux Φ = 4π I spreads over the bulb's surface 4π r_b², is transmitted by τ
    // and leaves a Lambertian diffuser: L = τ Φ / (4π r_b²) / π = τ I / (π r_b²)
    // (thesis Appendix I §19.2.1: E_on_bulb_glass, M_bulb = τ E, L = M/π).
    return spectralIntensity_W_sr_nm() * (glassTransmission / (kPi * bulbRadius_m * bulbRadius_m));
}

int Scene::materialIndex(const std::string& name) const {
    for (std::size_t i = 0; i < materials.size(); ++i) {
        if (materials[i].name == name) return static_cast<int>(i);
    }
    return -1;
}

int Scene::lampIndex(const std::string& name) const {
    for (std::size_t i = 0; i < lamps.size(); ++i) {
        if (lamps[i].name == name) return static_cast<int>(i);
    }
    return -1;
}

std::size_t Scene::triangleCount() const {
    std::size_t n = 0;
    for (const auto& o : objects)
        n += o.mesh.triangleCount();
    return n;
}

void Scene::validate() const {
    const std::string where = file.empty() ? std::string("scene") : file.string();
    if (triangleCount() == 0) throw SetupError(where + ": empty scene: no triangles to render");
    if (materials.empty()) throw SetupError(where + ": scene has no materials");
    if (materials.size() > std::numeric_limits<std::uint16_t>::max()) {
        throw SetupError(where + ": too many materials");
    }
    for (const auto& o : objects) {
        const Mesh& m = o.mesh;
        if (m.vertices_m.size() % 3 != 0 || m.triangles.size() % 3 != 0 ||
            m.materials.size() != m.triangleCount()) {
            throw SetupError(o.loc, "object '" + o.name + "': inconsistent mesh arrays");
        }
        for (float v : m.vertices_m) {
            if (!std::isfinite(v)) throw SetupError(o.loc, "object '" + o.name + "': NaN vertex");
        }
        for (std::uint32_t i : m.triangles) {
            if (i >= m.vertexCount()) {
                throw SetupError(o.loc, "object '" + o.name + "': vertex index out of range");
            }
        }
        for (std::uint16_t k : m.materials) {
            if (k >= materials.size()) {
                throw SetupError(o.loc, "object '" + o.name + "': material index out of range");
            }
        }
    }
    for (const auto& l : lamps) {
        if (!(l.projectedArea_m2 > 0.0))
            throw SetupError(l.loc, "lamp '" + l.name + "': no filament");
    }
}

Mesh loadObjMesh(const std::filesystem::path& path,
                 const std::vector<std::pair<std::string, int>>& layerMaterial, int defaultMaterial,
                 const FileLoc& from) {
    if (!pathExists(path)) {
        throw SetupError(from, "mesh file not found: " + path.string());
    }
    return parseObjMesh(readInputFile(path, kMaxMeshFileBytes, "OBJ mesh"), path.string(),
                        layerMaterial, defaultMaterial);
}

Mesh parseObjMesh(const std::string& text, const std::string& name,
                  const std::vector<std::pair<std::string, int>>& layerMaterial,
                  int defaultMaterial) {
    checkVertexLines(text, name);
    tinyobj::ObjReaderConfig cfg;
    cfg.triangulate = true;
    cfg.vertex_color = false;
    cfg.mtl_search_path = "";
    tinyobj::ObjReader reader;
    if (!reader.ParseFromString(text, "", cfg)) {
        throw SetupError(FileLoc{name}, "cannot parse OBJ: " + reader.Error());
    }
    const auto& attrib = reader.GetAttrib();
    Mesh mesh;
    mesh.vertices_m.reserve(attrib.vertices.size());
    for (std::size_t i = 0; i < attrib.vertices.size(); ++i) {
        const double v = static_cast<double>(attrib.vertices[i]);
        if (!std::isfinite(v)) {
            const int line = nthLineStartingWith(text, "v ", i / 3);
            throw SetupError(FileLoc{name, line},
                             "vertex " + std::to_string(i / 3 + 1) + " is not a finite number");
        }
        mesh.vertices_m.push_back(static_cast<float>(v));
    }
    for (const auto& shape : reader.GetShapes()) {
        int mat = defaultMaterial;
        for (const auto& [layer, idx] : layerMaterial) {
            if (layer == shape.name) mat = idx;
        }
        if (mat < 0) {
            const int line = shape.name.empty() ? 0 : groupLine(text, shape.name);
            throw SetupError(FileLoc{name, line},
                             "group '" + shape.name +
                                 "' has no material (map it in [layers] or give the object a "
                                 "material)");
        }
        std::size_t offset = 0;
        const std::size_t vertexCount = attrib.vertices.size() / 3;
        for (std::size_t f = 0; f < shape.mesh.num_face_vertices.size(); ++f) {
            const std::size_t n = shape.mesh.num_face_vertices[f];
            if (offset + n > shape.mesh.indices.size()) {
                throw SetupError(FileLoc{name}, "group '" + shape.name + "': inconsistent faces");
            }
            if (n == 3) {
                for (std::size_t k = 0; k < 3; ++k) {
                    const int vi = shape.mesh.indices[offset + k].vertex_index;
                    if (vi < 0 || static_cast<std::size_t>(vi) >= vertexCount) {
                        throw SetupError(FileLoc{name}, "group '" + shape.name +
                                                            "': a face refers to vertex " +
                                                            std::to_string(vi + 1) + " of " +
                                                            std::to_string(vertexCount));
                    }
                    mesh.triangles.push_back(static_cast<std::uint32_t>(vi));
                }
                mesh.materials.push_back(static_cast<std::uint16_t>(mat));
            }
            offset += n;
        }
    }
    return mesh;
}

Scene loadScene(const std::filesystem::path& path) {
    if (!pathExists(path)) throw SetupError("scene file not found: " + path.string());
    const ConfigDocument doc = ConfigDocument::parseFile(path);
    const ConfigTable root = doc.root();
    const std::filesystem::path dir = path.parent_path();
    Scene s;
    s.file = path;

    // Materials --------------------------------------------------------------------------
    for (const ConfigTable& t : root.tableArray("material")) {
        Material m;
        m.name = t.require<std::string>("name");
        m.loc = t.location("name");
        if (s.materialIndex(m.name) >= 0) t.fail("name", "duplicate material '" + m.name + "'");
        if (t.contains("reflectance_file")) {
            const auto rel = t.require<std::string>("reflectance_file");
            const auto column = t.get<std::string>("column", "reflectance_rel");
            const std::filesystem::path f = dir / rel;
            if (!pathExists(f)) {
                t.fail("reflectance_file", "file not found: " + f.string());
            }
            const TabulatedSpectrum tab = loadSpectrumCsv(f, "wavelength_nm", column);
            m.reflectance = tab.resample(Extrapolation::Clamp);
            m.source = tab.source;
        } else if (t.contains("reflectance")) {
            const double rho = t.require<double>("reflectance");
            m.reflectance = greyReflectance(rho);
            m.source = t.get<std::string>("source", "");
        } else {
            t.fail("name", "material '" + m.name + "' needs reflectance or reflectance_file");
        }
        for (int i = 0; i < Spectrum::size(); ++i) {
            if (!(m.reflectance[i] >= 0.0 && m.reflectance[i] <= 1.0)) {
                t.fail(t.contains("reflectance") ? "reflectance" : "reflectance_file",
                       "reflectance must lie in [0, 1]");
            }
        }
        m.specularity = t.get<double>("specularity", 0.0);
        if (!(m.specularity >= 0.0 && m.specularity <= 1.0)) {
            t.fail("specularity", "must lie in [0, 1]");
        }
        // The thermal channel's material (config/thermal/materials.toml; docs/thermal.md). It
        // is checked there, against the library the scenario names.
        m.thermal = t.get<std::string>("thermal", "");
        if (t.contains("thermal")) m.thermalLoc = t.location("thermal");
        s.materials.push_back(std::move(m));
    }

    // Layer → material map (the thesis's AutoCAD layers, Table 14-1) --------------------------
    std::vector<std::pair<std::string, int>> layers;
    if (const auto lt = root.optionalTable("layers")) {
        for (const std::string& k : lt->keys()) {
            const auto mname = lt->require<std::string>(k);
            const int idx = s.materialIndex(mname);
            if (idx < 0) lt->fail(k, "unknown material '" + mname + "'");
            layers.emplace_back(k, idx);
        }
    }

    // Objects ----------------------------------------------------------------------------
    for (const ConfigTable& t : root.tableArray("object")) {
        Object o;
        o.name = t.require<std::string>("name");
        o.loc = t.location("name");
        int defaultMat = -1;
        if (t.contains("material")) {
            const auto mname = t.require<std::string>("material");
            defaultMat = s.materialIndex(mname);
            if (defaultMat < 0) t.fail("material", "unknown material '" + mname + "'");
        }
        const auto meshRel = t.require<std::string>("mesh");
        o.mesh = loadObjMesh(dir / meshRel, layers, defaultMat, t.location("mesh"));
        if (o.mesh.triangleCount() == 0) t.fail("mesh", "mesh has no faces: " + meshRel);
        o.position_m = vec3At(t, "position_m", {}, false);
        o.yaw_rad = t.get<double>("yaw_deg", 0.0) * kDeg;
        o.trackId = t.get<int>("track_id", -1);
        // The class reported with its truth box: 1 … 15 characters of [A-Za-z0-9_-], so that
        // the metadata's JSON holds it as it is and a frame's record keeps a fixed size.
        o.truthClass = t.get<std::string>("class", o.name);
        const bool classOk =
            !o.truthClass.empty() && o.truthClass.size() <= 15 &&
            o.truthClass.find_first_not_of(
                "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789_-") ==
                std::string::npos;
        if (o.trackId >= 0 && !classOk) {
            t.fail(t.contains("class") ? "class" : "name",
                   "a truth class is 1 to 15 letters, digits, '_' or '-': '" + o.truthClass + "'" +
                       (t.contains("class") ? "" : " (the object's name; set `class`)"));
        }
        if (t.contains("trajectory")) {
            // trajectory = [t_s, x, y, z, yaw_deg, t_s, x, ...] flattened keyframes.
            const auto k = t.require<std::vector<double>>("trajectory");
            if (k.empty() || k.size() % 5 != 0) {
                t.fail("trajectory", "must hold keyframes of 5 numbers: t_s, x, y, z, yaw_deg");
            }
            for (std::size_t i = 0; i < k.size(); i += 5) {
                Keyframe kf{k[i], {k[i + 1], k[i + 2], k[i + 3]}, k[i + 4] * kDeg};
                if (!o.trajectory.empty() && !(kf.t_s > o.trajectory.back().t_s)) {
                    t.fail("trajectory", "keyframe times must increase");
                }
                o.trajectory.push_back(kf);
            }
        }
        s.objects.push_back(std::move(o));
    }

    // Lamps ------------------------------------------------------------------------------
    for (const ConfigTable& t : root.tableArray("lamp")) {
        Lamp l;
        l.name = t.require<std::string>("name");
        l.loc = t.location("name");
        const auto kind = t.get<std::string>("kind", "tungsten");
        if (kind != "tungsten" && kind != "tungsten_halogen") {
            t.fail("kind", "unknown lamp kind '" + kind + "' (tungsten, tungsten_halogen)");
        }
        l.position_m = vec3At(t, "position_m", {}, true);
        const Vec3 axis = vec3At(t, "axis", {0.0, 0.0, -1.0}, false);
        if (!(norm(axis) > 0.0)) t.fail("axis", "must not be zero");
        l.axis = normalized(axis);
        l.temperature_K = positive(t, "temperature_K", kind == "tungsten" ? 2856.0 : 3100.0);
        if (t.contains("power_W")) {
            // A filament radiating a fraction η of its electrical power as a blackbody:
            // P η = σ T⁴ A_surf, and the mean projected area is A_surf/4 (Cauchy).
            const double p = positive(t, "power_W", 1.0);
            const double eta = t.get<double>("radiated_fraction", 0.9);
            if (!(eta > 0.0 && eta <= 1.0)) t.fail("radiated_fraction", "must lie in (0, 1]");
            constexpr double kSigma = 5.670374419e-8;
            const double t4 = std::pow(l.temperature_K, 4.0);
            l.projectedArea_m2 = p * eta / (kSigma * t4) / 4.0;
        } else {
            l.projectedArea_m2 = filamentProjectedArea_m2(positive(t, "filament_radius_m", 0.5e-3),
                                                          positive(t, "filament_length_m", 5e-3));
        }
        l.glassTransmission = t.get<double>("glass_transmission", 1.0);
        if (!(l.glassTransmission > 0.0 && l.glassTransmission <= 1.0)) {
            t.fail("glass_transmission", "must lie in (0, 1]");
        }
        l.bulbRadius_m = positive(t, "bulb_radius_m", 0.03);
        l.cutoff_rad = t.get<double>("cutoff_deg", 180.0) * kDeg;
        if (!(l.cutoff_rad > 0.0 && l.cutoff_rad <= kPi))
            t.fail("cutoff_deg", "must lie in (0, 180]");
        l.apertureDiameter_m = t.get<double>("aperture_diameter_m", 0.0);
        if (!(l.apertureDiameter_m >= 0.0)) t.fail("aperture_diameter_m", "must be ≥ 0");
        l.apertureSamples = t.get<int>("aperture_samples", 16);
        if (l.apertureSamples < 1 || l.apertureSamples > 64) {
            t.fail("aperture_samples", "must lie in 1..64");
        }
        l.on = t.get<bool>("on", true);
        if (t.contains("attach")) {
            const auto obj = t.get<std::string>("attach", "");
            for (std::size_t k = 0; k < s.objects.size(); ++k)
                if (s.objects[k].name == obj) l.attachObject = static_cast<int>(k);
            if (l.attachObject < 0) t.fail("attach", "no [[object]] named '" + obj + "'");
            if (l.hasAperture()) t.fail("attach", "an attached lamp cannot have an aperture");
        }
        if (s.lampIndex(l.name) >= 0) t.fail("name", "duplicate lamp '" + l.name + "'");
        s.lamps.push_back(l);
    }

    // Camera pose ------------------------------------------------------------------------
    if (const auto ct = root.optionalTable("camera")) {
        s.camera.position_m = vec3At(*ct, "position_m", {}, true);
        s.camera.target_m = vec3At(*ct, "target_m", {}, true);
        s.camera.up = vec3At(*ct, "up", {0.0, 0.0, 1.0}, false);
        s.camera.twist_rad = ct->get<double>("twist_deg", 0.0) * kDeg;
        if (!(norm(s.camera.target_m - s.camera.position_m) > 0.0)) {
            ct->fail("target_m", "must differ from position_m");
        }
    }
    root.skip("description");
    doc.finish();
    if (s.triangleCount() == 0) {
        throw SetupError(FileLoc{path.string()}, "empty scene: no [[object]] with triangles");
    }
    s.validate();
    return s;
}

void cameraAxes(const CameraPose& p, Vec3* forward, Vec3* right, Vec3* up) noexcept {
    const Vec3 fwd = normalized(p.target_m - p.position_m);
    Vec3 r = cross(fwd, p.up);
    if (!(norm(r) > 1e-9)) r = {1, 0, 0};
    r = normalized(r);
    const Vec3 u = cross(r, fwd);
    // Twist: rotation of the image about the line of sight.
    const double ct = std::cos(p.twist_rad), st = std::sin(p.twist_rad);
    *forward = fwd;
    *right = r * ct + u * st;
    *up = u * ct - r * st;
}

}  // namespace nvs::scene
