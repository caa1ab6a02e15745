//! Classical explicit Runge–Kutta 4: a reference for tests.

use super::system::{HeadInterval, StrandState, StrandSystem};
use crate::bodies::Placement;
use crate::kernels::kernel::Terms;

/// q̈ = M⁻¹ F(q, q̇) with the head and the bodies at `at`, into `acc`.
fn acceleration(
    system: &mut StrandSystem,
    at: &Placement,
    q: &[f64],
    v: &[f64],
    acc: &mut [f64],
) -> Result<(), String> {
    let terms = Terms {
        mass: true,
        force: true,
        ..Default::default()
    };
    system.assemble(at, q, v, terms);
    let ws = &mut system.workspace;
    ws.solver.matrix.copy_from(&ws.terms.mass);
    ws.solver.rhs_mut().copy_from_slice(&ws.terms.force);
    if !ws.solver.solve_spd() {
        let finite = q.iter().chain(v).all(|x| x.is_finite());
        let largest = q.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
        return Err(if finite {
            format!(
                "RK4: the mass matrix at a stage state is not positive definite (largest |q| = {largest:.3e} rad/m): \
                 the explicit steps have grown unstable (dt beyond the stability limit of the stiffest mode, \
                 which changes along the motion); use a smaller dt or an implicit integrator"
            )
        } else {
            "RK4: a stage state is not finite: the explicit steps diverged (dt beyond the stability limit \
             of the stiffest mode); use a smaller dt or an implicit integrator"
                .to_string()
        });
    }
    acc.copy_from_slice(ws.solver.solution());
    Ok(())
}

/// Classical RK4 on (q, q̇); a reference for tests (explicit: needs small steps).
pub fn rk4(
    system: &mut StrandSystem,
    interval: &HeadInterval,
    state: &mut StrandState,
) -> Result<(), String> {
    let h = interval.h;
    let (q, v) = (&mut state.q[..], &mut state.v[..]);
    let heads = [
        interval.at_start(),
        Placement::new(interval.state_at(0.5), interval.t + 0.5 * h),
        interval.at_end(),
    ];
    let n = q.len();
    let mut s = std::mem::take(&mut system.workspace.scratch);
    let result = (|| {
        let [qs, vs, acc, dq, dv, _] = &mut s;
        dq.fill(0.0);
        dv.fill(0.0);
        acc.fill(0.0);
        vs.copy_from_slice(v);
        // (c, weight, head at t + c h): stage state (q + c h k_q, v + c h k_v) of the previous stage
        for (c, weight, head) in [(0.0, 1.0, 0), (0.5, 2.0, 1), (0.5, 2.0, 1), (1.0, 1.0, 2)] {
            for i in 0..n {
                qs[i] = q[i] + c * h * vs[i];
                vs[i] = v[i] + c * h * acc[i];
            }
            acceleration(system, &heads[head], qs, vs, acc)?;
            for i in 0..n {
                dq[i] += weight * vs[i];
                dv[i] += weight * acc[i];
            }
        }
        for i in 0..n {
            q[i] += h / 6.0 * dq[i];
            v[i] += h / 6.0 * dv[i];
        }
        Ok(())
    })();
    system.workspace.scratch = s;
    result
}
