//! The candidates a landmarked chart is tried as, simplest first, and what
//! the constraint file rules out: given corners, seams, a square boundary
//! or the chart's own atlas island are the user's word, read against the
//! mesh as given, and no cut or separation overrides them.

use crate::chart::PreparedChart;
use crate::cut::facing::{Camera, Sight};
use crate::cut::prepare::Form;
use crate::domain::Domain;
use crate::param::region::Region;
use crate::pins::BoundaryChoice;
use glam::DVec2;

/// Where a candidate's free solve starts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Start {
    /// Its own start: the island, the conformal layout, or the camera's view.
    Own,
    /// Its solve on the square, mapped onto its region (a square layout
    /// inside the region is a free layout): free never does worse than the square.
    Square,
}

/// One way to lay the chart out.
#[derive(Debug, Clone, PartialEq)]
pub struct Candidate {
    pub form: Form,
    /// The boundary the solve picks where the file names none (`None`: the
    /// default rule, [`crate::domain::setup::decide`]).
    pub boundary: Option<BoundaryChoice>,
    pub start: Start,
}

impl Candidate {
    /// The chart as it comes, by the default rule.
    pub const AS_GIVEN: Candidate = Candidate {
        form: Form::AsGiven,
        boundary: None,
        start: Start::Own,
    };

    /// How a report names it: the form, the boundary, the start.
    pub fn describe(&self, domain: &Domain) -> String {
        let boundary = match domain {
            Domain::Square => "on the square",
            Domain::Free(_) => "free",
        };
        let start = match self.start {
            Start::Own => "",
            Start::Square => ", from its solve on the square",
        };
        format!("{}, {boundary}{start}", self.form.name())
    }
}

/// What the constraint file decides about the chart, which no candidate
/// may change.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Law {
    /// Corners given: the outer loop as given, on the square.
    pub corners: bool,
    /// Seams given: cut there and nowhere else.
    pub seams: bool,
    /// The boundary named in the file.
    pub boundary: Option<BoundaryChoice>,
    /// A region given: free inside it.
    pub region: bool,
    /// The chart has UVs in the written set: laid out again in its island.
    pub island: bool,
}

impl Law {
    /// The law of `base`, the chart as the file and the default rule make it.
    pub fn of(base: &PreparedChart, boundary: Option<BoundaryChoice>, region: Option<Region>) -> Law {
        Law {
            corners: base.corners.is_some(),
            seams: base.opening.seam_given,
            boundary,
            region: region.is_some(),
            island: base.domain.free().is_some_and(|f| f.island.is_some()),
        }
    }

    /// Whether the chart's shape may be changed: cut, or split around the
    /// landmarks.
    fn may_reshape(&self) -> bool {
        !self.corners && !self.seams && !self.island
    }
}

/// What is known about the chart before any candidate is tried.
#[derive(Debug, Clone)]
pub struct Chart {
    pub law: Law,
    /// It is a disk as it comes (holes allowed).
    pub disk: bool,
    /// The default rule puts it on the square.
    pub square_by_default: bool,
    /// The landmarks' positions and targets (layout coordinates).
    pub landmarks: Vec<(glam::DVec3, DVec2)>,
    /// The region a free chart takes (layout box).
    pub room: (DVec2, DVec2),
    /// The budget of a split around the landmarks (`None`: no split).
    pub budget: Option<crate::cut::separate::Budget>,
}

/// How a tried candidate ended, as far as choosing the next one goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Ended {
    Reached,
    Short,
    /// Short, laid out free: its solve on the square, mapped onto its
    /// region, may come closer (a square layout inside the region is a free
    /// layout).
    ShortFree,
    /// It could not be made or started.
    Dropped,
}

/// The candidates after `tried` (the candidates tried so far and how each
/// ended), simplest first: the chart as given (on the square where the
/// default puts it, then free, then free from its square solve), cut (then,
/// short free, from its square solve), as
/// the camera sees it, and the landmarks' surroundings; a disk is cut or
/// split only when no way of taking it as given reached its targets.
/// `None` when none is left.
pub fn next(chart: &Chart, tried: &[(Candidate, Ended)]) -> Option<Candidate> {
    let law = &chart.law;
    let as_given_free = Candidate {
        boundary: Some(BoundaryChoice::Free),
        ..Candidate::AS_GIVEN
    };
    let mut list: Vec<Candidate> = Vec::new();
    if chart.disk || law.seams {
        list.push(Candidate::AS_GIVEN);
        if chart.square_by_default && law.boundary.is_none() && !law.corners {
            list.push(as_given_free.clone());
        }
        let own_free = tried.iter().find(|(c, _)| {
            c.form == Form::AsGiven && c.start == Start::Own && (c.boundary.is_some() || !chart.square_by_default)
        });
        let free_allowed = !law.corners && law.boundary != Some(BoundaryChoice::Square);
        if free_allowed && own_free.is_some_and(|(_, e)| *e != Ended::Reached) {
            list.push(Candidate {
                start: Start::Square,
                ..own_free.expect("tried").0.clone()
            });
        }
    }
    // A disk that reached its targets as it comes keeps its shape: cut or
    // split only when no way of taking it as given reached them.
    let as_given_reached = tried
        .iter()
        .any(|(c, e)| c.form == Form::AsGiven && *e == Ended::Reached);
    if chart.disk && as_given_reached {
        return list.into_iter().find(|c| !tried.iter().any(|(t, _)| t == c));
    }
    if law.may_reshape() && (!chart.disk || law.boundary != Some(BoundaryChoice::Square)) {
        let cut = Candidate {
            form: Form::Cut,
            boundary: None,
            start: Start::Own,
        };
        // Free never does worse than the square, cut or not.
        if tried.iter().any(|(c, e)| *c == cut && *e == Ended::ShortFree) {
            list.push(cut.clone());
            list.push(Candidate {
                start: Start::Square,
                ..cut
            });
        } else {
            list.push(cut);
        }
    }
    if law.may_reshape() && law.boundary != Some(BoundaryChoice::Square) {
        let (points, targets): (Vec<_>, Vec<_>) = chart.landmarks.iter().copied().unzip();
        if let Some(camera) = Camera::fit(&points, &targets) {
            for sight in [Sight::Near, Sight::Whole, Sight::Grown] {
                list.push(Candidate {
                    form: Form::Facing {
                        camera,
                        room: chart.room,
                        sight,
                    },
                    boundary: Some(BoundaryChoice::Free),
                    start: Start::Own,
                });
            }
        }
        if let Some(budget) = chart.budget {
            list.push(Candidate {
                form: Form::Around(budget),
                boundary: Some(BoundaryChoice::Free),
                start: Start::Own,
            });
        }
    }
    list.into_iter().find(|c| !tried.iter().any(|(t, _)| t == c))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn chart(disk: bool, law: Law) -> Chart {
        Chart {
            law,
            disk,
            square_by_default: true,
            landmarks: vec![
                (glam::DVec3::new(0.0, 0.0, 0.0), DVec2::new(0.2, 0.2)),
                (glam::DVec3::new(1.0, 0.0, 0.1), DVec2::new(0.8, 0.2)),
                (glam::DVec3::new(0.0, 1.0, 0.2), DVec2::new(0.2, 0.8)),
                (glam::DVec3::new(1.0, 1.0, 0.0), DVec2::new(0.8, 0.8)),
            ],
            room: (DVec2::ZERO, DVec2::ONE),
            budget: None,
        }
    }

    const FREE_LAW: Law = Law {
        corners: false,
        seams: false,
        boundary: None,
        region: false,
        island: false,
    };

    fn all(chart: &Chart, end: Ended) -> Vec<Candidate> {
        let mut tried = Vec::new();
        while let Some(c) = next(chart, &tried) {
            tried.push((c, end));
        }
        tried.into_iter().map(|(c, _)| c).collect()
    }

    #[test]
    fn a_disk_is_tried_as_given_first_then_free_then_reshaped() {
        let list = all(&chart(true, FREE_LAW), Ended::Short);
        let forms: Vec<&str> = list.iter().map(|c| c.form.name()).collect();
        assert_eq!(forms[..3], ["as given", "as given", "as given"]);
        assert_eq!(list[1].boundary, Some(BoundaryChoice::Free));
        assert_eq!(list[2].start, Start::Square);
        assert!(forms.contains(&"cut") && forms.contains(&"as the camera sees it"));
    }

    #[test]
    fn given_corners_or_seams_keep_the_chart_as_given() {
        for law in [
            Law {
                corners: true,
                ..FREE_LAW
            },
            Law {
                seams: true,
                ..FREE_LAW
            },
            Law {
                island: true,
                ..FREE_LAW
            },
        ] {
            let list = all(&chart(true, law), Ended::Short);
            assert!(list.iter().all(|c| c.form == Form::AsGiven), "{law:?}: {list:?}");
        }
        let square = Law {
            boundary: Some(BoundaryChoice::Square),
            ..FREE_LAW
        };
        let list = all(&chart(true, square), Ended::Short);
        assert_eq!(
            list,
            vec![Candidate::AS_GIVEN],
            "a square boundary asked for: nothing else"
        );
    }

    #[test]
    fn a_disk_that_reached_as_given_is_never_cut() {
        let chart = chart(true, FREE_LAW);
        let first = next(&chart, &[]).expect("as given");
        let tried = vec![(first, Ended::Reached)];
        let mut all = tried.clone();
        while let Some(c) = next(&chart, &all) {
            all.push((c, Ended::Reached));
        }
        assert!(all.iter().all(|(c, _)| c.form == Form::AsGiven), "{all:?}");
    }

    #[test]
    fn a_closed_chart_is_cut_or_split_never_taken_as_given() {
        let list = all(&chart(false, FREE_LAW), Ended::Short);
        assert!(list.iter().all(|c| c.form != Form::AsGiven));
        assert_eq!(list[0].form, Form::Cut);
    }

    #[test]
    fn a_cut_chart_short_free_is_tried_from_its_square_solve_next() {
        let list = all(&chart(false, FREE_LAW), Ended::ShortFree);
        assert_eq!((list[0].form.name(), list[0].start), ("cut", Start::Own));
        assert_eq!((list[1].form.name(), list[1].start), ("cut", Start::Square));
        // Short on the square already: no square start to try.
        let list = all(&chart(false, FREE_LAW), Ended::Short);
        assert!(list.iter().all(|c| c.start == Start::Own), "{list:?}");
    }
}
