#pragma once
// Thermal materials for the surface heat balance (docs/thermal.md §1).
//
// A material has an optical part (LWIR band emissivity at normal incidence, its angular model,
// solar absorptance) and, for surfaces whose temperature is solved, a thermal part: layers
// from the exposed face inwards (thickness, conductivity, density, specific heat) and a back
// boundary. A heat source is either a back boundary (a person's core at 37 °C, an engine bay's
// air, a lamp's power through its housing) or a surface held at a fixed temperature (an
// exhaust pipe). Materials are read from a strict TOML file (config/thermal/materials.toml);
// every error is a SetupError naming file:line.
//
// Angular dependence of the emissivity (Kirchhoff: ε(θ) = 1 − R(θ) for an opaque surface):
//   "lambertian"  ε(θ) = ε_n (vegetation canopies, rough soil, textiles);
//   "dielectric"  ε(θ) = 1 − (R_s + R_p)/2, Fresnel reflectances of a smooth interface with a
//                 real index n fitted to the normal value, ε_n = 1 − ((n − 1)/(n + 1))²;
//   "metal"       the same with a complex index N = n(1 + i) (the Hagen–Rubens regime of the
//                 far infrared, where n ≈ k), fitted to ε_n = 4n/((n + 1)² + n²). ε rises
//                 towards grazing incidence and falls to 0 at 90°.
//   (Siegel & Howell, "Thermal Radiation Heat Transfer", 4th ed., Taylor & Francis 2002, §3.5
//   (Fresnel relations for dielectrics and metals) and §3.5.3 (Hagen–Rubens); Modest,
//   "Radiative Heat Transfer", 3rd ed., Academic Press 2013, §3.4.)
// The heat balance uses the hemispherical emissivity ε_h = 2∫ε(θ) cos θ sin θ dθ.

#include <filesystem>
#include <string>
#include <string_view>
#include <vector>

#include "sim/core/error.h"

namespace nvs::thermal {

enum class AngularModel { Lambertian, Dielectric, Metal };

// What lies behind the last layer.
enum class BackBoundary {
    Insulated,         // no heat flow (a thin plate on a stand; a thick symmetric slab)
    FixedTemperature,  // deep ground at its climatological temperature, a body core, an engine
    AirNode,           // an inside air node through a film coefficient (cabin, room)
};

struct Layer {
    double thickness_m = 0.0;
    double conductivity_W_mK = 0.0;
    double density_kg_m3 = 0.0;
    double specificHeat_J_kgK = 0.0;
};

struct ThermalMaterial {
    std::string name;
    FileLoc loc;  // the material's table in its file
    double emissivityNormal = 0.95;
    AngularModel angular = AngularModel::Lambertian;
    double solarAbsorptance = 0.7;
    // DOE-2 surface roughness multiplier R_f of the forced convection (1.0 glass … 2.17 very
    // rough stucco; ASHRAE Handbook of Fundamentals / EnergyPlus Engineering Reference).
    double roughnessMultiplier = 1.0;

    std::vector<Layer> layers;  // exposed face first; empty: an optical-only material
    BackBoundary back = BackBoundary::Insulated;
    double backTemperature_K = 0.0;     // FixedTemperature, or AirNode when !backFollowsAir
    bool backFollowsAir = false;        // AirNode at the outside air temperature (plus offset)
    double backAirOffset_K = 0.0;       // AirNode following the air: its offset
    double backFilm_W_m2K = 0.0;        // AirNode: film coefficient
    double backFlux_W_m2 = 0.0;         // heat put in at the back (a lamp's power per area)
    double surfaceTemperature_K = 0.0;  // > 0: a source held at this temperature, no layers
    bool collectsDew = true;            // dew condenses on it (and evaporates again)
    // Transpiration through a surface resistance [s/m] by day (Sun up) and by night; 0: none.
    double surfaceResistanceDay_s_m = 0.0;
    double surfaceResistanceNight_s_m = 0.0;

    // Derived at load: the index fitted to ε_n and the hemispherical emissivity.
    double index_n = 1.0;  // real part (dielectric), n = k (metal)
    double emissivityHemispherical = 0.95;

    bool hasThermal() const { return !layers.empty() || surfaceTemperature_K > 0.0; }
};

// Directional emissivity ε(θ) for cos θ in [0, 1] (clamped), by the material's angular model.
double directionalEmissivity(const ThermalMaterial& m, double cosTheta) noexcept;
// ε(θ) of a smooth interface with a complex index n + ik (Fresnel, unpolarised).
double fresnelEmissivity(double n, double k, double cosTheta) noexcept;
// Hemispherical emissivity 2∫ε(θ) cos θ sin θ dθ (composite Simpson in θ, 512 intervals).
double hemisphericalEmissivity(const ThermalMaterial& m);
// Completes the derived fields (index, hemispherical emissivity); throws SetupError at m.loc
// when a value is out of range (emissivity outside (0, 1], negative thickness, ...).
void finishMaterial(ThermalMaterial& m);

class MaterialLibrary {
  public:
    static MaterialLibrary load(const std::filesystem::path& path);
    static MaterialLibrary parse(std::string_view text, const std::string& name);
    // From materials built in code (tests, scenario-local materials); each already finished.
    static MaterialLibrary fromList(std::vector<ThermalMaterial> materials, std::string source);

    // The material by name; throws SetupError at `askedAt` if it is not in the library.
    const ThermalMaterial& get(std::string_view name, const FileLoc& askedAt) const;
    // As get, and the material must have thermal properties: a material without them names
    // both places ("askedAt: material 'x' (file:line) has no thermal layers").
    const ThermalMaterial& requireThermal(std::string_view name, const FileLoc& askedAt) const;
    const std::vector<ThermalMaterial>& all() const { return materials_; }
    const std::string& source() const { return source_; }

  private:
    std::vector<ThermalMaterial> materials_;
    std::string source_;
};

}  // namespace nvs::thermal
