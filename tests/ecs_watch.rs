//! The daemon's incremental rules on a bare World (no watcher, no process):
//! file events go in as messages, the watch schedule runs, components and
//! counters are checked.

mod common;

use bevy_ecs::prelude::*;
use common::{TempDir, write_constraints, write_mesh_glb};
use std::path::{Path, PathBuf};
use std::sync::Arc;
use uvpin::complete::pattern::PendingNewtonPattern;
use uvpin::config::{LogFormat, OutputMode};
use uvpin::daemon::charts::*;
use uvpin::daemon::events::{FileEvent, FileRules};
use uvpin::daemon::log::Logger;
use uvpin::daemon::paths::WatchRoot;
use uvpin::daemon::registry::{WatchCounters, WatchSettings};
use uvpin::daemon::status::StatusBoard;
use uvpin::ecs::*;
use uvpin::report::Status;
use uvpin::testing::grid_mesh;

const N: usize = 12;
const A: u32 = (6 + 6 * N) as u32;

struct Fixture {
    _dir: TempDir,
    root: PathBuf,
    world: World,
    schedule: Schedule,
}

impl Fixture {
    fn new(name: &str) -> Self {
        let dir = TempDir::new(name);
        let root = dir.0.canonicalize().unwrap().join("assets");
        std::fs::create_dir_all(&root).unwrap();
        write_mesh_glb(&root.join("grid.glb"), &grid_mesh(N, N));
        let mut world = World::new();
        init_watch_world(
            &mut world,
            WatchSettings {
                input: uvpin::io::InputRules {
                    limits: uvpin::io::InputLimits::DEFAULT,
                    scope: uvpin::io::ReadScope::within([root.clone()]),
                },
                settle: std::time::Duration::from_millis(1),
                roots: vec![WatchRoot {
                    path: root.clone(),
                    single_file: false,
                }],
                output: OutputMode::Folder(root.parent().unwrap().join("out")),
                rules: FileRules {
                    constraint_suffix: ".uvpin.ron".into(),
                    own: Vec::new(),
                },
                defaults: uvpin::options::SolverOptions::DEFAULT,
                cwd: root.parent().unwrap().to_path_buf(),
                previews: None,
            },
            DaemonLog {
                logger: Logger {
                    format: LogFormat::Human,
                },
                status: StatusBoard::new(root.join("unused.json")),
                write_status: false,
                status_error: None,
            },
        );
        Fixture {
            _dir: dir,
            root,
            world,
            schedule: watch_schedule(),
        }
    }

    fn ron(&self) -> PathBuf {
        self.root.join("grid.uvpin.ron")
    }

    fn write(&self, u: f64, extra: &str) {
        write_constraints(&self.ron(), Path::new("grid.glb"), &[(A, u, 0.45)], extra);
    }

    fn send(&mut self, event: FileEvent) {
        handle(&mut self.world, &[event]);
    }

    fn run(&mut self) {
        run_to_convergence(&mut self.world, &mut self.schedule, 100_000);
    }

    fn entity(&self) -> Entity {
        self.world.resource::<DaemonState>().entities[&self.ron()]
    }

    fn counters(&self) -> WatchCounters {
        self.world.resource::<DaemonState>().registry.counters
    }

    fn factor(&self) -> Arc<uvpin::param::bar_net::BarNet> {
        self.session().bar_net().expect("factor").clone()
    }

    fn newton_pattern(&self) -> Arc<PendingNewtonPattern> {
        self.session().pattern().expect("Newton pattern").clone()
    }

    fn session(&self) -> uvpin::session::ChartSession {
        self.world.get::<Session>(self.entity()).expect("session").0.clone()
    }

    fn report(&self) -> uvpin::report::Report {
        self.world
            .get::<Exported>(self.entity())
            .expect("exported")
            .0
            .report
            .clone()
    }
}

#[test]
fn a_constraint_edit_re_solves_from_the_cached_step1_layout_without_refactoring() {
    let mut f = Fixture::new("ecs-watch-edit");
    f.write(0.50, "");
    let root = f.root.clone();
    f.send(FileEvent::FolderAppeared(root));
    f.run();
    let first = f.report();
    assert_eq!(first.status, Status::Reached);
    assert!(first.times.factor_ms > 0.0);
    let factor = f.factor();
    let newton = f.newton_pattern();
    let step1 = f.session().step_one_layout().unwrap().to_vec();

    f.write(0.53, "");
    let ron = f.ron();
    f.send(FileEvent::ConstraintsChanged(ron));
    f.run();
    let second = f.report();
    assert_eq!(second.status, Status::Reached);
    assert!((second.constraints[0].target.x - 0.53).abs() < 1e-12);
    assert!(second.constraints[0].residual <= 1e-9);
    assert!(Arc::ptr_eq(&factor, &f.factor()), "the bar-net factor was rebuilt");
    assert!(
        Arc::ptr_eq(&newton, &f.newton_pattern()),
        "the Newton pattern was rebuilt"
    );
    assert_eq!(second.times.factor_ms, 0.0);
    assert_eq!(second.times.boundary_ms, 0.0);
    assert_eq!(second.times.solve_ms, 0.0, "step 1 was solved again");
    assert_eq!(f.session().step_one_layout().unwrap(), step1);
    let c = f.counters();
    assert_eq!((c.solves_started, c.geometry_reused, c.step1_reused), (2, 1, 1));

    // New corners: a new boundary map and step 1, on the same factorisation.
    f.write(
        0.53,
        "    corners: (top_left: 0, bottom_left: 11, bottom_right: 143, top_right: 132),\n",
    );
    let ron = f.ron();
    f.send(FileEvent::ConstraintsChanged(ron));
    f.run();
    let third = f.report();
    assert!(third.times.boundary_ms > 0.0 && third.times.solve_ms > 0.0);
    assert_eq!(third.times.factor_ms, 0.0);
    assert!(Arc::ptr_eq(&factor, &f.factor()));
    // The same outer loop, so the same free set: the Newton pattern serves on.
    assert!(Arc::ptr_eq(&newton, &f.newton_pattern()));
    let c = f.counters();
    assert_eq!((c.solves_started, c.geometry_reused, c.step1_reused), (3, 2, 1));
}

#[test]
fn an_event_without_a_content_change_does_nothing() {
    let mut f = Fixture::new("ecs-watch-same");
    f.write(0.50, "");
    let ron = f.ron();
    f.send(FileEvent::ConstraintsChanged(ron.clone()));
    f.run();
    let before = f.counters();
    let written_at = std::fs::metadata(f.root.parent().unwrap().join("out/grid.glb"))
        .unwrap()
        .modified()
        .unwrap();
    // Rewritten with identical bytes, and the asset touched the same way.
    f.write(0.50, "");
    let glb = std::fs::read(f.root.join("grid.glb")).unwrap();
    std::fs::write(f.root.join("grid.glb"), glb).unwrap();
    f.send(FileEvent::ConstraintsChanged(ron));
    f.send(FileEvent::AssetChanged(f.root.join("grid.glb")));
    f.schedule.run(&mut f.world);
    let after = f.counters();
    assert_eq!(after.solves_started, before.solves_started);
    assert_eq!(after.unchanged, before.unchanged + 2);
    assert!(
        f.world.get::<Exported>(f.entity()).is_some(),
        "the finished solve was reset"
    );
    let now = std::fs::metadata(f.root.parent().unwrap().join("out/grid.glb"))
        .unwrap()
        .modified()
        .unwrap();
    assert_eq!(now, written_at, "the output was rewritten");
}

#[test]
fn an_asset_edit_redoes_everything() {
    let mut f = Fixture::new("ecs-watch-asset");
    f.write(0.50, "");
    let ron = f.ron();
    f.send(FileEvent::ConstraintsChanged(ron));
    f.run();
    let factor = f.factor();
    let newton = f.newton_pattern();
    let mut mesh = grid_mesh(N, N);
    for p in &mut mesh.positions {
        p.z = 0.2 * (p.y * 3.0).sin();
    }
    write_mesh_glb(&f.root.join("grid.glb"), &mesh);
    let glb = f.root.join("grid.glb");
    f.send(FileEvent::AssetChanged(glb));
    f.run();
    let report = f.report();
    assert_eq!(report.status, Status::Reached);
    assert!(report.times.factor_ms > 0.0);
    assert!(!Arc::ptr_eq(&factor, &f.factor()));
    assert!(!Arc::ptr_eq(&newton, &f.newton_pattern()));
    assert_eq!(f.counters().geometry_reused, 0);
}

#[test]
fn a_newer_edit_supersedes_a_running_solve_and_only_the_newest_is_written() {
    let mut f = Fixture::new("ecs-watch-supersede");
    f.write(0.50, "");
    let ron = f.ron();
    f.send(FileEvent::ConstraintsChanged(ron.clone()));
    f.schedule.run(&mut f.world);
    assert!(is_busy(&mut f.world), "one tick should not finish the solve");
    f.write(0.56, "");
    f.send(FileEvent::ConstraintsChanged(ron));
    f.run();
    let report = f.report();
    assert!((report.constraints[0].target.x - 0.56).abs() < 1e-12);
    assert_eq!(f.counters().solves_started, 2);
    let out = f.root.parent().unwrap().join("out/grid.glb");
    let asset = uvpin::io::load_asset(&out, None, 0, &Default::default()).unwrap();
    let uv = asset.primitives[0].uvs.as_ref().unwrap()[A as usize];
    assert!(
        (f64::from(uv[0]) - 0.56).abs() < 1e-6 && (f64::from(uv[1]) - 0.45).abs() < 1e-6,
        "{uv:?}"
    );
}
