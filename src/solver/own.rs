//! A chart laid out on its own: free inside the texture, without
//! landmarks. Its stretch is the yardstick of a landmarked layout (a
//! candidate is good enough within [`ACCEPT`] of it, a partial layout too
//! stretched is replaced by it), and the charts packed beside a landmarked
//! one are laid out so.

use crate::chart::PreparedChart;
use crate::constraints::ConstraintSource;
use crate::domain::Domain;
use crate::free::FreeSetup;
use crate::metrics::{Stretch, sander_stretch};
use crate::options::SolverOptions;
use crate::pins::{BoundaryChoice, Pins};
use crate::solver::{ChartSolver, SolverInputs, step_one};
use glam::DVec2;
use std::sync::Arc;

/// A candidate that reaches its targets with a stretch within this factor
/// of its chart's own free layout needs no other tried after it; a reached
/// layout is polished to within it (at any size).
pub const ACCEPT: f64 = 1.5;

/// `prepared`'s chart as a free chart without landmarks, inside the whole
/// texture with nothing around it.
pub fn unconstrained(prepared: &PreparedChart) -> PreparedChart {
    let setup = FreeSetup::open_texture();
    PreparedChart {
        constraints: Vec::new(),
        constraint_vertices: Vec::new(),
        corners: None,
        domain: Domain::Free(Arc::new(setup)),
        secondary: Vec::new(),
        rest_share: 0.0,
        ..prepared.clone()
    }
}

/// The source of a solve without landmarks.
pub fn no_landmarks() -> ConstraintSource {
    ConstraintSource::Memory(Arc::new(Pins::new(&[]).with_boundary(BoundaryChoice::Free)))
}

/// `piece` (a chart without landmarks, free) solved: from its coarse level
/// when it is large, else from step 1; `None` when the solve fails.
pub fn solve(piece: &PreparedChart, options: &SolverOptions) -> Option<ChartSolver> {
    let source = no_landmarks();
    let path = std::path::Path::new("");
    let boundary = step_one::map_boundary(piece, &source).ok()?;
    let inputs = SolverInputs {
        prepared: piece,
        source: &source,
        options,
        boundary: &boundary,
        step1: &[],
        bar_net: None,
        pattern: None,
        elapsed_ms: 0.0,
    };
    let coarse = (piece.filled.mesh.n_vertices() > options.multilevel_above)
        .then(|| ChartSolver::from_coarse_level(inputs).ok()?.ok())
        .flatten();
    let mut solver = match coarse {
        Some(solver) => solver,
        None => {
            let net = step_one::factor_bar_net(piece, &boundary, path).ok()?;
            let step1 = step_one::solve_force_density(piece, &boundary, &net);
            ChartSolver::new(SolverInputs {
                step1: &step1,
                bar_net: Some(&net),
                ..inputs
            })
            .ok()?
        }
    };
    solver.run().ok()?;
    Some(solver)
}

/// The free layout of `prepared`'s chart without its landmarks (the filled
/// chart's), one-to-one; `None` when it cannot be laid out so.
pub fn free_layout(prepared: &PreparedChart, options: &SolverOptions) -> Option<Vec<DVec2>> {
    let piece = unconstrained(prepared);
    let solver = solve(&piece, options)?;
    let triangles = &piece.filled.mesh.triangles;
    let clean = crate::guard::all_positive_as_stored(solver.layout(), triangles)
        && solver
            .free()
            .is_some_and(|f| f.domain.room.admits(solver.layout()).is_ok());
    clean.then(|| solver.layout().to_vec())
}

/// The Sander stretch of `layout` over `prepared`'s real triangles.
pub fn stretch(prepared: &PreparedChart, layout: &[DVec2]) -> Stretch {
    let f = &prepared.filled;
    sander_stretch(&f.mesh.positions, layout, &f.mesh.triangles[..f.n_real_triangles])
}

/// The stretch of `prepared`'s chart laid out on its own ([`free_layout`]).
pub fn own_stretch(prepared: &PreparedChart, options: &SolverOptions) -> Option<Stretch> {
    free_layout(prepared, options)
        .map(|l| stretch(prepared, &l))
        .filter(|s| s.l2.is_finite())
}
