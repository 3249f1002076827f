//! Fixed-step integration with events: classical Runge-Kutta 4 inside a sub-step, and location of
//! the instant where an event function changes sign (velocity reversal, end stop, breakaway,
//! backlash contact) so that the mode switch happens there and not at the end of the sub-step.

/// One classical RK4 step of `x' = f(x)` over `h`.
#[inline(always)]
pub fn rk4<const N: usize, F: Fn(&[f64; N]) -> [f64; N]>(x: &[f64; N], h: f64, f: F) -> [f64; N] {
    let k1 = f(x);
    let mut tmp = [0.0; N];
    for i in 0..N {
        tmp[i] = x[i] + 0.5 * h * k1[i];
    }
    let k2 = f(&tmp);
    for i in 0..N {
        tmp[i] = x[i] + 0.5 * h * k2[i];
    }
    let k3 = f(&tmp);
    for i in 0..N {
        tmp[i] = x[i] + h * k3[i];
    }
    let k4 = f(&tmp);
    let mut out = [0.0; N];
    for i in 0..N {
        out[i] = x[i] + h / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]);
    }
    out
}

/// Find `t` in `(0, h]` where `g` changes from positive to non-positive, knowing `g(0) = g0 > 0`
/// and `g(h) = g1 <= 0`; `g(t)` integrates from the start of the step. Illinois variant of
/// regula falsi; returns a time at or just after the crossing, so that the event has happened.
pub fn locate<G: FnMut(f64) -> f64>(mut g: G, h: f64, g0: f64, g1: f64) -> f64 {
    if g0 <= 0.0 {
        return 0.0;
    }
    let (mut a, mut fa, mut b, mut fb) = (0.0, g0, h, g1);
    let tol = h * 1e-10;
    let mut side = 0i8;
    for _ in 0..40 {
        if b - a <= tol {
            break;
        }
        let mut c = (a * fb - b * fa) / (fb - fa);
        if !(c > a && c < b) {
            c = 0.5 * (a + b);
        }
        let fc = g(c);
        if fc > 0.0 {
            a = c;
            fa = fc;
            if side == 1 {
                fb *= 0.5;
            }
            side = 1;
        } else {
            b = c;
            fb = fc;
            if fc == 0.0 {
                break;
            }
            if side == -1 {
                fa *= 0.5;
            }
            side = -1;
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rk4_exponential_is_fourth_order() {
        let x = rk4(&[1.0], 0.1, |x| [-x[0]]);
        assert!((x[0] - (-0.1f64).exp()).abs() < 1e-7);
    }

    #[test]
    fn locate_finds_root() {
        // x' = -1 from x = 0.3: crosses 0 at t = 0.3.
        let g = |t: f64| 0.3 - t;
        let t = locate(g, 1.0, 0.3, -0.7);
        assert!((t - 0.3).abs() < 1e-9);
    }
}
