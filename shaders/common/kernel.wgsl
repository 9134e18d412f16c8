// Smoothing kernels (cubic spline, quintic, Wendland C2, quadratic), matching src/core/kernel.rs.
// Needs the scene constants KERNEL (one of KERNEL_CUBIC_SPLINE, KERNEL_QUINTIC,
// KERNEL_WENDLAND_C2, KERNEL_QUADRATIC), KERNEL_H (smoothing length h) and KERNEL_SCALE (σ_d / h^d).
// The `_at` forms take a smoothing length of their own (an adaptive h); the others are
// them at KERNEL_H.

fn kernel_w(r: f32) -> f32 {
    return kernel_w_at(r, KERNEL_H);
}

// σ_d/h^d at smoothing length h: KERNEL_SCALE (KERNEL_H/h)^d, exactly KERNEL_SCALE at
// h = KERNEL_H.
fn kernel_scale_at(h: f32) -> f32 {
    let ratio = KERNEL_H / h;
    var scale = KERNEL_SCALE * ratio * ratio;
    if DIM == 3u {
        scale *= ratio;
    }
    return scale;
}

fn kernel_w_at(r: f32, h: f32) -> f32 {
    let q = r / h;
    var w = 0.0;
    if KERNEL == KERNEL_CUBIC_SPLINE {
        if q < 1.0 {
            w = 1.0 - 1.5 * q * q + 0.75 * q * q * q;
        } else if q < 2.0 {
            let t = 2.0 - q;
            w = 0.25 * t * t * t;
        }
    } else if KERNEL == KERNEL_QUINTIC {
        let t3 = max(3.0 - q, 0.0);
        let t2 = max(2.0 - q, 0.0);
        let t1 = max(1.0 - q, 0.0);
        w = pow5(t3) - 6.0 * pow5(t2) + 15.0 * pow5(t1);
    } else if KERNEL == KERNEL_WENDLAND_C2 {
        if q < 2.0 {
            let t = 1.0 - 0.5 * q;
            w = t * t * t * t * (2.0 * q + 1.0);
        }
    } else if q < 2.0 {
        w = 0.1875 * q * q - 0.75 * q + 0.75;
    }
    return kernel_scale_at(h) * w;
}

fn pow5(t: f32) -> f32 {
    let t2 = t * t;
    return t2 * t2 * t;
}

// dW/dr (≤ 0).
fn kernel_dw(r: f32) -> f32 {
    return kernel_dw_at(r, KERNEL_H);
}

fn kernel_dw_at(r: f32, h: f32) -> f32 {
    let q = r / h;
    var d = 0.0;
    if KERNEL == KERNEL_CUBIC_SPLINE {
        if q < 1.0 {
            d = -3.0 * q + 2.25 * q * q;
        } else if q < 2.0 {
            let t = 2.0 - q;
            d = -0.75 * t * t;
        }
    } else if KERNEL == KERNEL_QUINTIC {
        let t3 = max(3.0 - q, 0.0);
        let t2 = max(2.0 - q, 0.0);
        let t1 = max(1.0 - q, 0.0);
        d = -5.0 * (t3 * t3 * t3 * t3 - 6.0 * t2 * t2 * t2 * t2 + 15.0 * t1 * t1 * t1 * t1);
    } else if KERNEL == KERNEL_WENDLAND_C2 {
        if q < 2.0 {
            let t = 1.0 - 0.5 * q;
            d = -5.0 * q * t * t * t;
        }
    } else if q < 2.0 {
        d = 0.375 * q - 0.75;
    }
    return kernel_scale_at(h) / h * d;
}

// ∇W_ij = ∂W(x_i − x_j)/∂x_i; zero for the self pair.
fn kernel_grad(x_ij: vecd) -> vecd {
    return kernel_grad_at(x_ij, KERNEL_H);
}

fn kernel_grad_at(x_ij: vecd, h: f32) -> vecd {
    let r = length(x_ij);
    if r <= 1e-6 * h {
        return vecd(0.0);
    }
    return x_ij * (kernel_dw_at(r, h) / r);
}
