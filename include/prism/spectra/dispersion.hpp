// prism/spectra/dispersion.hpp — index-of-refraction spectra eta(lambda) for
// dielectrics, and the rule that ties them to the wavelengths a path carries.
//
// Three laws, each a type with Float operator()(Float lambda_nm) (lambda in nm,
// in vacuum; eta relative to the medium outside, air or vacuum):
//  - ConstantIOR: eta(lambda) = eta, no dispersion;
//  - SellmeierIOR: eta^2 = 1 + sum_i B_i l^2 / (l^2 - C_i), l in MICROMETRES,
//    C_i in um^2, up to 4 terms (glass catalogues: SCHOTT, Malitson, Daimon);
//    SellmeierIOR::glass(name) looks a glass up in prism::data::sellmeier_glasses;
//  - AbbeIOR: the KHR_materials_dispersion law, eta_d and an Abbe number V_d
//    (stored as the extension's `dispersion` = 20 / V_d): the two-term Cauchy
//    law eta = A + B / lambda^2 fitted so that eta(lambda_d) = eta_d and
//    eta(lambda_F) - eta(lambda_C) = (eta_d - 1) / V_d, which the extension
//    writes with rounded constants as
//        eta(lambda) = eta_d + (eta_d - 1) / V_d * (523655 / lambda^2 - 1.5168).
// IOR holds any of the three (std::variant), says whether it disperses and
// validates it over the visible range.
//
// The rule (docs/dispersion.md): a path that meets a dispersive interface can
// follow one direction only, so it keeps its hero wavelength lambda[0] and
// terminates the secondary ones (SampledWavelengths::terminate_secondary);
// path_eta() applies it, for any refractive BxDF.
#pragma once
#include <array>
#include <cmath>
#include <sstream>
#include <string>
#include <string_view>
#include <type_traits>
#include <variant>
#include "prism/error.hpp"
#include "prism/math/float.hpp"
#include "prism/spectra/data/sellmeier.hpp"

namespace prism {

// Fraunhofer lines used to define the Abbe number V_d = (n_d - 1) / (n_F - n_C).
inline constexpr Float lambda_d_nm = 587.56f;  // helium d line
inline constexpr Float lambda_F_nm = 486.13f;  // hydrogen F line
inline constexpr Float lambda_C_nm = 656.27f;  // hydrogen C line

// The range validate() checks (the range the spectral renderer samples).
inline constexpr int ior_check_min_nm = 360, ior_check_max_nm = 830;

struct ConstantIOR {
  Float eta = 1.5f;
  Float operator()(Float) const { return eta; }
};

class SellmeierIOR {
 public:
  static constexpr int max_terms = 4;

  // Coefficients B_i (dimensionless) and C_i (um^2); unused terms are 0.
  SellmeierIOR() = default;
  SellmeierIOR(const std::array<double, max_terms>& B, const std::array<double, max_terms>& C_um2)
      : m_B(B), m_C(C_um2) {}

  // A glass of prism::data::sellmeier_glasses by name ("N-BK7", "fused_silica",
  // "N-SF11", "N-BAF10", "water_20C"); throws prism::Error listing the known
  // names otherwise.
  static SellmeierIOR glass(std::string_view name) {
    for (const auto& row : data::sellmeier_glasses)
      if (name == row.name)
        return SellmeierIOR({row.B[0], row.B[1], row.B[2], row.B[3]},
                            {row.C_um2[0], row.C_um2[1], row.C_um2[2], row.C_um2[3]});
    throw Error("unknown Sellmeier glass '" + std::string(name) + "'; known glasses: " + known_glasses());
  }
  // "N-BK7, fused_silica, ..." in catalogue order.
  static std::string known_glasses() {
    std::string s;
    for (const auto& row : data::sellmeier_glasses) {
      if (!s.empty()) s += ", ";
      s += row.name;
    }
    return s;
  }

  // eta at lambda (nm), in double: NaN where eta^2 < 0, +-Inf at a pole C_i = l^2.
  double eval(double lambda_nm) const {
    double l2 = sqr(lambda_nm * 1e-3);  // um^2
    double n2 = 1;
    for (int i = 0; i < max_terms; ++i)
      if (m_B[size_t(i)] != 0) n2 += m_B[size_t(i)] * l2 / (l2 - m_C[size_t(i)]);
    return std::sqrt(n2);
  }
  Float operator()(Float lambda_nm) const { return Float(eval(double(lambda_nm))); }

  // A term with C_i = 0 adds the constant B_i; any other non-zero term disperses.
  bool is_dispersive() const {
    for (int i = 0; i < max_terms; ++i)
      if (m_B[size_t(i)] != 0 && m_C[size_t(i)] != 0) return true;
    return false;
  }
  const std::array<double, max_terms>& B() const { return m_B; }
  const std::array<double, max_terms>& C_um2() const { return m_C; }

 private:
  std::array<double, max_terms> m_B{}, m_C{};
};

// KHR_materials_dispersion: `dispersion` = 20 / V_d, 0 meaning no dispersion.
struct AbbeIOR {
  Float eta_d = 1.5f;
  Float dispersion = 0;

  static AbbeIOR from_abbe_number(Float eta_d, Float V_d) { return {eta_d, 20 / V_d}; }
  Float abbe_number() const { return dispersion != 0 ? 20 / dispersion : infinity; }

  double eval(double lambda_nm) const {
    // 523655 ~ 1 / (lambda_F^-2 - lambda_C^-2) and 1.5168 ~ 523655 / lambda_d^2
    // (nm): the extension's constants, used as published.
    double inv_V = double(dispersion) / 20;
    return double(eta_d) + (double(eta_d) - 1) * inv_V * (523655.0 / sqr(lambda_nm) - 1.5168);
  }
  Float operator()(Float lambda_nm) const { return Float(eval(double(lambda_nm))); }
  bool is_dispersive() const { return dispersion != 0; }
};

class IOR {
 public:
  using law_type = std::variant<ConstantIOR, SellmeierIOR, AbbeIOR>;

  IOR() = default;  // constant 1.5
  IOR(Float eta) : m_law(ConstantIOR{eta}) {}  // NOLINT: a number is a constant IOR
  IOR(ConstantIOR c) : m_law(c) {}
  IOR(SellmeierIOR s) : m_law(s) {}
  IOR(AbbeIOR a) : m_law(a) {}

  Float operator()(Float lambda_nm) const {
    return std::visit([&](const auto& law) { return Float(law(lambda_nm)); }, m_law);
  }
  // eta at the d line: what RGB rendering uses.
  Float eta_d() const { return (*this)(lambda_d_nm); }

  // False for a constant IOR and for an Abbe law with dispersion 0.
  bool is_dispersive() const {
    return std::visit(
        [](const auto& law) {
          if constexpr (std::is_same_v<std::decay_t<decltype(law)>, ConstantIOR>)
            return false;
          else
            return law.is_dispersive();
        },
        m_law);
  }

  // Throws prism::Error naming the material unless eta is finite and > 1 at
  // every nm from 360 to 830 (and an Abbe law's dispersion is finite and >= 0,
  // as KHR_materials_dispersion requires).
  void validate(std::string_view material_name) const {
    auto fail = [&](const std::string& what) {
      throw Error("material '" + std::string(material_name) + "': " + what);
    };
    if (const auto* a = std::get_if<AbbeIOR>(&m_law))
      if (!std::isfinite(a->dispersion) || a->dispersion < 0) {
        std::ostringstream s;
        s << "Abbe dispersion (20 / V_d) must be finite and >= 0, got " << a->dispersion;
        fail(s.str());
      }
    for (int l = ior_check_min_nm; l <= ior_check_max_nm; ++l) {
      Float eta = (*this)(Float(l));
      if (!std::isfinite(eta) || !(eta > 1)) {
        std::ostringstream s;
        s << law_name() << " index of refraction is " << eta << " at " << l
          << " nm; it must be finite and greater than 1 from " << ior_check_min_nm << " to " << ior_check_max_nm
          << " nm";
        fail(s.str());
      }
    }
  }

  std::string_view law_name() const {
    constexpr std::string_view names[] = {"constant", "Sellmeier", "Abbe"};
    return names[m_law.index()];
  }
  const law_type& law() const { return m_law; }

 private:
  law_type m_law{ConstantIOR{}};
};

// The relative IOR a refractive BxDF built at a path vertex uses, given the
// path's wavelengths (SampledWavelengths<N>, or RGBWavelengths in RGB mode):
//  - RGB mode: eta at the d line;
//  - spectral mode, non-dispersive: the same eta for every wavelength, and all
//    N wavelengths go on;
//  - spectral mode, dispersive: eta at the hero wavelength lambda[0], and the
//    secondary wavelengths are terminated (only when lambda is non-const: a
//    caller passing const wavelengths, such as a test probing a material,
//    gets the hero's eta without side effects).
template <class W>
Float path_eta(const IOR& ior, W& lambda) {
  if constexpr (std::remove_cvref_t<W>::is_spectral) {
    if (!ior.is_dispersive()) return ior.eta_d();
    if constexpr (!std::is_const_v<W>) lambda.terminate_secondary();
    return ior(lambda[0]);
  } else {
    (void)lambda;
    return ior.eta_d();
  }
}

}  // namespace prism
