//! Energies of strands' states, measured without touching the stepping simulation.
//!
//! The runtime measures a strand's energy (`Simulation::kinetic_energy`, `energy`) on its
//! strand system: the embedded engine on a system made afresh for each call, the runtime
//! engine in the strand's own workspace and with its contacts, whose potential depends on
//! what they tracked over the run (depenetration, friction anchors, hair–hair partners).
//! So that an energy is a function of the state alone, and measuring never changes the
//! steps, the runtime engine's strands are measured on a second simulation of the scene
//! without contacts, electrostatics or bodies, set to the state measured: the energy is
//! kinetic + elastic + gravity + point loads.

use superhelix_runtime::config::Engine;
use superhelix_runtime::{Simulation, SimulationSetup};

/// Measures (kinetic, potential) energies of the strands of one simulation.
pub struct EnergyMeter {
    setup: SimulationSetup,
    measuring: Option<Simulation>,
}

impl EnergyMeter {
    /// A meter for simulations of `setup` (the second simulation is built on first use).
    pub fn new(setup: &SimulationSetup) -> EnergyMeter {
        let mut setup = setup.clone();
        setup.contacts = None;
        setup.electrostatics = None;
        setup.bodies = Vec::new();
        setup.output.render = None;
        setup.config.engine = Engine::Runtime;
        setup.config.tolerance = None;
        EnergyMeter {
            setup,
            measuring: None,
        }
    }

    /// (kinetic, potential) of strand `i` of `main` in the state (q, q̇) given, or in its
    /// present state; J. With the embedded engine `main` is set to the given state (its
    /// measurement is pure); with the runtime engine it is only read.
    pub fn measure(
        &mut self,
        main: &mut Simulation,
        i: usize,
        state: Option<(&[f64], &[f64])>,
    ) -> Result<(f64, f64), String> {
        if main.engine() == Engine::Embedded {
            if let Some((q, v)) = state {
                main.set_state(i, q, v);
            }
            let t = main.kinetic_energy(i);
            return Ok((t, main.energy(i) - t));
        }
        if self.measuring.is_none() {
            let built = Simulation::new(self.setup.clone(), crate::scene::kernels())
                .map_err(|e| format!("the simulation measuring energies: {e}"))?;
            self.measuring = Some(built);
        }
        let Some(m) = self.measuring.as_mut() else {
            return Err("the simulation measuring energies is missing".to_string());
        };
        match state {
            Some((q, v)) => m.set_state(i, q, v),
            None => m.set_state(i, main.q(i), main.v(i)),
        }
        let t = m.kinetic_energy(i);
        Ok((t, m.energy(i) - t))
    }
}
