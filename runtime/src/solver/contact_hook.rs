//! The runtime's contacts of one strand as the one step's hooks
//! (`superhelix_kernels::fixed::ContactHooks`): the bodies, the hair–hair partners and
//! their pairs of two parts of the strand, the Coulomb anchors and allowances and the
//! contacts that start within a step, kept in the runtime's storage
//! ([`StrandContacts`]), their law and queries the kernels'
//! (`superhelix_kernels::contact`), the strand's points from the step's own terms (its
//! kernel's). The step calls them where the embedded engine's `FixedContacts` are
//! called: the two differ in storage only.

use crate::bodies::Placement;
use crate::forces::contacts::predicted::PredictedContacts;
use crate::forces::contacts::StrandContacts;
use crate::forces::head_motion::HeadState;
use crate::StrandGeometry;
use nalgebra::Vector3;
use superhelix_kernels::contact::body::BodySummary;
use superhelix_kernels::contact::predicted::{self, PredictionHost, SingularStep, GAP_TOLERANCE};
use superhelix_kernels::fixed::ContactHooks;
use superhelix_kernels::storage::Square;
use superhelix_kernels::strand_terms::StrandPoints;

/// A strand's contacts as the one step's hooks, with the scratch they lend.
pub struct ContactHook<'a> {
    /// The contacts.
    pub contacts: &'a mut StrandContacts,
    /// The strand's geometry.
    pub geometry: &'a StrandGeometry,
    /// Scratch: J(s), 3N columns.
    pub jac: &'a mut [Vector3<f64>],
    /// The contact energy and rate of the last measure of the energy balance.
    pub last_contact: &'a mut (f64, f64),
    /// The end of the step whose bookkeeping the caller does itself (after the pair solve
    /// of `coupling = "pair"`, which moves the strand after its step): the step's own call
    /// at that time is left out.
    pub end_deferred: Option<f64>,
}

impl ContactHooks<f64> for ContactHook<'_> {
    fn start(&mut self, q: &[f64], t: f64, head: &HeadState) {
        self.contacts
            .start(&Placement::new(*head, t), self.geometry, q);
    }

    /// The simulation starts a strand's contacts before its first step (and a
    /// checkpoint restores them).
    fn started(&self) -> bool {
        true
    }

    fn add_terms(
        &mut self,
        points: &mut dyn StrandPoints<f64>,
        q: &[f64],
        v: &[f64],
        t: f64,
        head: &HeadState,
        curvature: bool,
        force: &mut [f64],
        stiffness: &mut Square<'_, f64>,
        damping: &mut Square<'_, f64>,
    ) -> bool {
        self.contacts.add_step_terms(
            &Placement::new(*head, t),
            self.geometry,
            points,
            (q, v),
            curvature,
            self.jac,
            force,
            stiffness,
            damping,
        )
    }

    fn energy(
        &mut self,
        points: &mut dyn StrandPoints<f64>,
        q: &[f64],
        v: &[f64],
        t: f64,
        head: &HeadState,
    ) -> (f64, f64) {
        let at = Placement::new(*head, t);
        let (potential, rate) = self.contacts.energy(&at, self.geometry, q);
        let power =
            self.contacts
                .drag_power_with(&at, self.geometry, q, v, self.jac, &mut |s, jac| {
                    points.point(q, s, jac)
                });
        (potential, rate + power)
    }

    fn acceptable(
        &mut self,
        q0: &[f64],
        q1: &[f64],
        t0: f64,
        head0: &HeadState,
        t1: f64,
        head1: &HeadState,
    ) -> bool {
        self.contacts.step_acceptable(
            &Placement::new(*head0, t0),
            &Placement::new(*head1, t1),
            self.geometry,
            q0,
            q1,
        )
    }

    fn after_step(&mut self, q: &[f64], t: f64, head: &HeadState, h: f64) {
        if self.end_deferred == Some(t) {
            return;
        }
        self.contacts
            .after_step(&Placement::new(*head, t), self.geometry, q, h);
    }

    fn has_history(&self) -> bool {
        self.contacts.has_history()
    }

    fn moves_relative(&self, t0: f64, t1: f64, head0: &HeadState, head1: &HeadState) -> bool {
        self.contacts
            .moves_relative(&Placement::new(*head0, t0), &Placement::new(*head1, t1))
    }

    fn has_partners(&self) -> bool {
        self.contacts.has_partners()
    }

    fn deepest(&mut self, q: &[f64], t: f64, head: &HeadState) -> f64 {
        self.contacts
            .deepest_inside(&Placement::new(*head, t), self.geometry, q)
    }

    fn summary(&self) -> BodySummary {
        let s = self.contacts.summary();
        BodySummary {
            contacts: s.body_contacts,
            max_penetration: s.max_penetration,
            normal_force: s.normal_force,
        }
    }

    fn touching(&self) -> bool {
        let s = self.contacts.summary();
        s.body_contacts + s.hair_contacts > 0
    }

    fn last_contact(&mut self) -> &mut (f64, f64) {
        self.last_contact
    }

    fn forget(&mut self) {
        self.contacts.predicted_mut().forget();
    }

    fn predict(&mut self, q_lin: &[f64], q_pred: &[f64], t: f64, head: &HeadState) -> bool {
        self.contacts
            .predict(&Placement::new(*head, t), self.geometry, q_lin, q_pred)
    }

    fn resolve(
        &mut self,
        points: &mut dyn StrandPoints<f64>,
        q: &mut [f64],
        v: &mut [f64],
        map: Option<(f64, f64)>,
        t: f64,
        head: &HeadState,
        solve: &mut dyn FnMut(&mut [f64]) -> bool,
    ) -> Result<usize, SingularStep> {
        if !self.contacts.has_bodies() {
            return Ok(0);
        }
        let tolerance = GAP_TOLERANCE * self.contacts.params().radius;
        let mut pc = std::mem::take(self.contacts.predicted_mut());
        let at = Placement::new(*head, t);
        let mut host = Host {
            contacts: &mut *self.contacts,
            points,
            solve,
            jac: &mut *self.jac,
            geom: self.geometry,
            at: &at,
            dofs: v.len(),
        };
        let result = match map {
            Some(map) => predicted::resolve(&mut pc, &mut host, map, tolerance, q, v),
            None => predicted::resolve_again(&mut pc, &mut host, tolerance, q, v),
        };
        *self.contacts.predicted_mut() = pc;
        result
    }
}

/// The one step as the resolution's host of the contacts that start within it: its
/// factors, the strand's points from its terms, the end check on the runtime's storage.
struct Host<'s, 'p> {
    contacts: &'s mut StrandContacts,
    points: &'s mut (dyn StrandPoints<f64> + 'p),
    solve: &'s mut dyn FnMut(&mut [f64]) -> bool,
    jac: &'s mut [Vector3<f64>],
    geom: &'s StrandGeometry,
    at: &'s Placement,
    dofs: usize,
}

impl PredictionHost<PredictedContacts> for Host<'_, '_> {
    fn solve_factored(&mut self, x: &mut [f64]) -> bool {
        (self.solve)(x)
    }
    fn linearize(&mut self, buffers: &mut PredictedContacts, from: usize) {
        let points = &mut *self.points;
        predicted::linearize(buffers, self.dofs, from, self.jac, |q, s, jac| {
            points.point(q, s, jac);
        });
    }
    fn end_check(&mut self, buffers: &mut PredictedContacts, q: &[f64]) -> usize {
        self.contacts
            .check_predicted(buffers, self.at, self.geom, q)
    }
}
