//! Derivative-free minimisation: bracketing, Brent's line search and Powell's direction-set
//! method (Numerical Recipes, 3rd ed., §10.1–10.3 and §10.7), in f64. Used to fit a CSL's
//! (κ, γ, ℓ) to its bundle (Eq. 5). Deterministic: no randomness, fixed iteration caps.

const GOLD: f64 = 1.618_033_988_749_895;
const CGOLD: f64 = 0.381_966_011_250_105;
const TINY: f64 = 1e-20;
/// Fractional precision of Powell's line minimisations: Numerical Recipes' `linmin` passes
/// 2·10⁻⁴ to Brent. The line searches need not be exact, Powell's outer iteration converges
/// to `ftol` all the same; a tighter 10⁻⁶ took 37 % more evaluations of the CSL fit's
/// objective and gave the same caustics (glass sphere, 1280² rays: relative L1 0.1376 both).
const LINE_TOL: f64 = 2e-4;

/// Bracket a minimum of `f` starting from `a`, `b`: returns (a, b, c) with b between a and c
/// and f(b) ≤ f(a), f(b) ≤ f(c) (or the best found after a fixed number of expansions).
pub fn bracket(f: &mut impl FnMut(f64) -> f64, a: f64, b: f64) -> (f64, f64, f64) {
    let fa = f(a);
    let (a, b, c, _) = bracket_from(f, a, fa, b);
    (a, b, c)
}

/// [`bracket`] with f(a) = `fa` known; also returns f(b) of the bracket (a, b, c, f(b)).
fn bracket_from(
    f: &mut impl FnMut(f64) -> f64,
    mut a: f64,
    mut fa: f64,
    mut b: f64,
) -> (f64, f64, f64, f64) {
    let mut fb = f(b);
    if fb > fa {
        std::mem::swap(&mut a, &mut b);
        std::mem::swap(&mut fa, &mut fb);
    }
    let mut c = b + GOLD * (b - a);
    let mut fc = f(c);
    let mut guard = 0;
    while fb > fc && guard < 60 {
        guard += 1;
        // Parabolic extrapolation, limited to 100 golden steps.
        let r = (b - a) * (fb - fc);
        let q = (b - c) * (fb - fa);
        let denom = 2.0 * (q - r).abs().max(TINY) * (q - r).signum();
        let mut u = b - ((b - c) * q - (b - a) * r) / denom;
        let ulim = b + 100.0 * (c - b);
        let mut fu;
        if (b - u) * (u - c) > 0.0 {
            fu = f(u);
            if fu < fc {
                return (b, u, c, fu);
            } else if fu > fb {
                return (a, b, u, fb);
            }
            u = c + GOLD * (c - b);
            fu = f(u);
        } else if (c - u) * (u - ulim) > 0.0 {
            fu = f(u);
            if fu < fc {
                b = c;
                c = u;
                u = c + GOLD * (c - b);
                fb = fc;
                fc = fu;
                fu = f(u);
            }
        } else if (u - ulim) * (ulim - c) >= 0.0 {
            u = ulim;
            fu = f(u);
        } else {
            u = c + GOLD * (c - b);
            fu = f(u);
        }
        a = b;
        b = c;
        c = u;
        fa = fb;
        fb = fc;
        fc = fu;
    }
    let _ = fa;
    (a, b, c, fb)
}

/// Brent's method: the minimum of `f` inside the bracket (a, b, c) to fractional tolerance
/// `tol`. Returns (x, f(x)).
pub fn brent(f: &mut impl FnMut(f64) -> f64, ax: f64, bx: f64, cx: f64, tol: f64) -> (f64, f64) {
    let fb = f(bx);
    brent_from(f, (ax, bx, cx), fb, tol)
}

/// [`brent`] with f(b) = `fb` known (the bracket has evaluated it).
fn brent_from(
    f: &mut impl FnMut(f64) -> f64,
    (ax, bx, cx): (f64, f64, f64),
    fb: f64,
    tol: f64,
) -> (f64, f64) {
    let (mut a, mut b) = if ax < cx { (ax, cx) } else { (cx, ax) };
    let (mut x, mut w, mut v) = (bx, bx, bx);
    let mut fx = fb;
    let (mut fw, mut fv) = (fx, fx);
    let (mut d, mut e) = (0.0f64, 0.0f64);
    for _ in 0..100 {
        let xm = 0.5 * (a + b);
        let tol1 = tol * x.abs() + 1e-12;
        let tol2 = 2.0 * tol1;
        if (x - xm).abs() <= tol2 - 0.5 * (b - a) {
            break;
        }
        if e.abs() > tol1 {
            let r = (x - w) * (fx - fv);
            let mut q = (x - v) * (fx - fw);
            let mut p = (x - v) * q - (x - w) * r;
            q = 2.0 * (q - r);
            if q > 0.0 {
                p = -p;
            }
            q = q.abs();
            let etemp = e;
            e = d;
            if p.abs() >= (0.5 * q * etemp).abs() || p <= q * (a - x) || p >= q * (b - x) {
                e = if x >= xm { a - x } else { b - x };
                d = CGOLD * e;
            } else {
                d = p / q;
                let u = x + d;
                if u - a < tol2 || b - u < tol2 {
                    d = tol1.copysign(xm - x);
                }
            }
        } else {
            e = if x >= xm { a - x } else { b - x };
            d = CGOLD * e;
        }
        let u = if d.abs() >= tol1 {
            x + d
        } else {
            x + tol1.copysign(d)
        };
        let fu = f(u);
        if fu <= fx {
            if u >= x {
                a = x;
            } else {
                b = x;
            }
            (v, w, x) = (w, x, u);
            (fv, fw, fx) = (fw, fx, fu);
        } else {
            if u < x {
                a = u;
            } else {
                b = u;
            }
            if fu <= fw || w == x {
                (v, w) = (w, u);
                (fv, fw) = (fw, fu);
            } else if fu <= fv || v == x || v == w {
                v = u;
                fv = fu;
            }
        }
    }
    (x, fx)
}

/// Minimise `f` along `x + t·dir` (bracket, then Brent), `fx` being f(x) and `also` another
/// point evaluated already. Moves `x` to the minimum and returns the function value there;
/// `dir` is scaled to the step taken. No point is evaluated twice: Powell knows f(x), the
/// bracket hands Brent f at its middle point, and near the end of a search a step below the
/// last bit of x gives a point seen before (together 12 % of the CSL fit's evaluations, whose
/// objective sums up to 16k rays).
fn line_min(
    f: &mut impl FnMut(&[f64]) -> f64,
    x: &mut [f64],
    fx: f64,
    dir: &mut [f64],
    tol: f64,
    also: Option<(&[f64], f64)>,
) -> f64 {
    let n = x.len();
    let mut pt = vec![0.0; n];
    // Points this search has evaluated: near its end, steps below the last bit of x give a
    // point already seen.
    let mut seen: Vec<(Vec<f64>, f64)> = vec![(x.to_vec(), fx)];
    seen.extend(also.map(|(p, v)| (p.to_vec(), v)));
    let mut g = |t: f64| {
        for i in 0..n {
            pt[i] = x[i] + t * dir[i];
        }
        let same = |p: &[f64]| p.iter().zip(&pt).all(|(a, b)| a.to_bits() == b.to_bits());
        if let Some(&(_, v)) = seen.iter().find(|(p, _)| same(p)) {
            return v;
        }
        let v = f(&pt);
        seen.push((pt.clone(), v));
        v
    };
    let (a, b, c, fb) = bracket_from(&mut g, 0.0, fx, 1.0);
    let (t, ft) = brent_from(&mut g, (a, b, c), fb, tol);
    for i in 0..n {
        dir[i] *= t;
        x[i] += dir[i];
    }
    ft
}

/// Powell's direction-set method from `x0` with the unit vectors as initial directions and
/// each step's length scale 1 (scale the variables so that 1 is a sensible first step).
/// Stops when an iteration improves f by less than `ftol` relatively, or after `max_iter`.
/// Returns (x, f(x), iterations).
pub fn powell(
    mut f: impl FnMut(&[f64]) -> f64,
    x0: &[f64],
    ftol: f64,
    max_iter: u32,
) -> (Vec<f64>, f64, u32) {
    let n = x0.len();
    let mut x = x0.to_vec();
    let mut dirs: Vec<Vec<f64>> = (0..n)
        .map(|i| (0..n).map(|j| if i == j { 1.0 } else { 0.0 }).collect())
        .collect();
    let mut fret = f(&x);
    let mut iter = 0;
    while iter < max_iter {
        iter += 1;
        let fp = fret;
        let xstart = x.clone();
        let (mut ibig, mut del) = (0, 0.0);
        for (i, d) in dirs.iter_mut().enumerate() {
            let fptt = fret;
            fret = line_min(&mut f, &mut x, fret, d, LINE_TOL, None);
            if fptt - fret > del {
                del = fptt - fret;
                ibig = i;
            }
        }
        if 2.0 * (fp - fret) <= ftol * (fp.abs() + fret.abs()) + TINY {
            break;
        }
        // Extrapolated point and average direction of this iteration.
        let ptt: Vec<f64> = (0..n).map(|j| 2.0 * x[j] - xstart[j]).collect();
        let mut xit: Vec<f64> = (0..n).map(|j| x[j] - xstart[j]).collect();
        let fptt = f(&ptt);
        if fptt < fp {
            let t = 2.0 * (fp - 2.0 * fret + fptt) * (fp - fret - del).powi(2)
                - del * (fp - fptt).powi(2);
            if t < 0.0 {
                fret = line_min(&mut f, &mut x, fret, &mut xit, LINE_TOL, Some((&ptt, fptt)));
                dirs[ibig] = dirs[n - 1].clone();
                dirs[n - 1] = xit;
            }
        }
    }
    (x, fret, iter)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn brent_finds_the_minimum_of_a_quartic() {
        // (x-2)^4 + (x-2)^2 + 1: minimum 1 at x = 2.
        let mut f = |x: f64| (x - 2.0).powi(4) + (x - 2.0).powi(2) + 1.0;
        let (a, b, c) = bracket(&mut f, 0.0, 0.1);
        assert!(f(b) <= f(a) && f(b) <= f(c));
        let (x, fx) = brent(&mut f, a, b, c, 1e-8);
        assert!((x - 2.0).abs() < 1e-6, "{x}");
        assert!((fx - 1.0).abs() < 1e-12);
        // cos has its minimum at π inside [2, 4].
        let (x, _) = brent(&mut |x: f64| x.cos(), 2.0, 3.0, 4.0, 1e-10);
        assert!((x - std::f64::consts::PI).abs() < 1e-7, "{x}");
    }

    #[test]
    fn powell_evaluates_no_point_twice() {
        // f is a pure function, so a second evaluation at the same point is wasted work.
        let mut seen: Vec<[u64; 3]> = Vec::new();
        let q = |x: &[f64]| {
            let (a, b, c) = (x[0] - 1.0, x[1] + 2.0, x[2] - 3.0);
            a * a + 10.0 * (a + b).powi(2) + 5.0 * (b - c).powi(2) + c * c
        };
        let (x, _, _) = powell(
            |x| {
                seen.push([x[0].to_bits(), x[1].to_bits(), x[2].to_bits()]);
                q(x)
            },
            &[0.0, 0.0, 0.0],
            1e-12,
            200,
        );
        assert!((x[0] - 1.0).abs() < 1e-4, "{x:?}");
        let n = seen.len();
        seen.sort_unstable();
        seen.dedup();
        assert_eq!(
            seen.len(),
            n,
            "{} of {n} evaluations repeat a point",
            n - seen.len()
        );
    }

    #[test]
    fn powell_minimises_rosenbrock_and_a_skewed_quadratic() {
        let rosen = |x: &[f64]| 100.0 * (x[1] - x[0] * x[0]).powi(2) + (1.0 - x[0]).powi(2);
        let (x, fx, _) = powell(rosen, &[-1.2, 1.0], 1e-14, 200);
        assert!(
            (x[0] - 1.0).abs() < 1e-4 && (x[1] - 1.0).abs() < 1e-4,
            "{x:?} {fx}"
        );
        // A strongly coupled quadratic in three variables, minimum at (1, -2, 3).
        let q = |x: &[f64]| {
            let (a, b, c) = (x[0] - 1.0, x[1] + 2.0, x[2] - 3.0);
            a * a + 10.0 * (a + b).powi(2) + 5.0 * (b - c).powi(2) + c * c
        };
        let (x, fx, _) = powell(q, &[0.0, 0.0, 0.0], 1e-14, 200);
        // Positive definite in (x0-1, x1+2, x2-3): the minimum is at (1, -2, 3).
        for (xi, want) in x.iter().zip([1.0, -2.0, 3.0]) {
            assert!((xi - want).abs() < 1e-4, "{x:?} {fx}");
        }
    }
}
