#pragma once
// Linear least squares by the normal equations, accumulated one observation at a time (the
// structure shapes fit up to 15 coefficients over every pixel of many frames, so the design
// matrix is never stored), solved by GSL's SVD: a basis the data do not span (a level with no
// pixel) leaves a singular value that is dropped instead of failing.

#include <vector>

namespace nvs::fit {

class NormalEquations {
  public:
    explicit NormalEquations(int k);
    // One observation y with regressors x[0..k).
    void add(const double* x, double y);
    // The coefficients; singular values below 1e-10 of the largest are dropped.
    std::vector<double> solve() const;

  private:
    int k_;
    std::vector<double> A_, b_;
};

}  // namespace nvs::fit
