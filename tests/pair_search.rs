//! Issue 76, item 1: a search that cannot miss a pair. The gap stage fits pairs chosen by a
//! screen ([`PairSearch::Screen`]); these tests hold its first five to those of fitting every
//! pair of the library ([`PairSearch::Every`]) on the real balance-assist study and on blind
//! campaigns and studies, each diagnosed from the same files both ways.

use bikeproc::blind::{in_scratch, stage};
use bikeproc::gap::{
    diagnose_campaign_with, diagnose_manifests_with, Diagnosis, GapOptions, PairSearch,
};
use bikeproc::inertia::bike::LabBike;
use bikeproc::read::rides::RideManifest;
use bikeproc::read::study::Study;
use bikeproc::sim::campaign::{blind_campaign_plus, BlindDesign, Draws, Withheld};
use bikeproc::sim::study::{blind_study_with, StudyMotor};
use common::root;

mod common;

fn options(pairs: PairSearch) -> GapOptions {
    GapOptions {
        pairs,
        ..Default::default()
    }
}

/// The first `k` candidates: each one's effects and whether it is needed, in order.
fn first(d: &Diagnosis, k: usize) -> Vec<(String, bool)> {
    d.ranking
        .iter()
        .take(k)
        .map(|r| (r.effect.clone(), r.not_needed))
        .collect()
}

/// Whether the diagnosis fitted any pair (the screen is what chose them).
fn tried_pairs(d: &Diagnosis) -> bool {
    d.ranking.iter().any(|r| r.effects.len() > 1)
}

fn lab() -> (LabBike, String) {
    let path = root().join("data/lab_bike.toml");
    (
        LabBike::load(&path).unwrap(),
        std::fs::read_to_string(&path).unwrap(),
    )
}

/// A campaign where the screen's first pair is not the best: a spring on the steer (outside the
/// library) on the varied design, seed 505. Fitting every pair, the default in a campaign,
/// finds `wheel_spin + frame_inertia` (held out 1.586), which predicts the rides left out better
/// than the screen's first, `front_ixx + wheel_spin` (1.709): the screen never fitted it. (Until
/// the dry friction joined the library, its campaign on the noted design, seed 500, was this
/// case; the library's friction now closes that gap alone.)
#[test]
fn a_campaign_fits_every_pair_and_finds_what_the_screen_missed() {
    let (lab, text) = lab();
    let (files, _) = blind_campaign_plus(
        &lab,
        "bike.toml",
        Withheld::SteerSpring,
        BlindDesign::Varied,
        505,
        &[],
        Draws::Broad,
    )
    .unwrap();
    let [standard, screen, every] = in_scratch("pairs_spring", &files, &text, &|dir| {
        let manifest = RideManifest::load(&dir.join("rides.toml")).map_err(stage)?;
        let model = bikeproc::read::bicycle::load(&dir.join("bike.toml")).map_err(stage)?;
        let run = |p| {
            diagnose_campaign_with(&manifest, &model, &options(p), &|_, _, _| {}).map_err(stage)
        };
        Ok([
            run(PairSearch::Standard)?,
            run(PairSearch::Screen)?,
            run(PairSearch::Every)?,
        ])
    })
    .unwrap();
    assert!(tried_pairs(&every), "no single closes this campaign's gap");
    assert_eq!(first(&standard, 5), first(&every, 5));
    let (best, screened) = (&standard.ranking[0], &screen.ranking[0]);
    assert!(
        screen.ranking.len() < every.ranking.len(),
        "{} candidates screened, {} of every pair",
        screen.ranking.len(),
        every.ranking.len()
    );
    assert!(
        best.heldout_rms_after <= screened.heldout_rms_after,
        "every pair's first {} ({:.3}) against the screen's {} ({:.3})",
        best.effect,
        best.heldout_rms_after,
        screened.effect,
        screened.heldout_rms_after
    );
}

/// A blind study whose best single does not close the gap, so that the screen chooses its
/// pairs: seed 2 (69 candidates fitted by the screen, 276 by every pair, 29 ranked by each;
/// of seeds 1–10 the only one since the conditions left out are whitened together: the others'
/// best single passes, and both searches then fit the same 26 or 43 candidates). The first
/// five the same, in order, each needed or not alike.
#[test]
fn a_studys_screen_finds_the_first_five_of_every_pair() {
    let (lab, text) = lab();
    let (files, _) = blind_study_with(&lab, "bike.toml", 2, StudyMotor::DRAWN).unwrap();
    let [(standard, screened), (every, all)] = in_scratch("pairs_study_2", &files, &text, &|dir| {
        let study = Study::load(&dir.join("study.toml")).map_err(stage)?;
        let model =
            bikeproc::read::bicycle::load(&study.bike_path().map_err(stage)?).map_err(stage)?;
        let run = |p| {
            // The candidates the search fits, as its progress counts them.
            let total = std::sync::atomic::AtomicUsize::new(0);
            let d = diagnose_manifests_with(&study.conditions, &model, &options(p), &|s, _, n| {
                if s == "candidates" {
                    total.fetch_max(n, std::sync::atomic::Ordering::SeqCst);
                }
            })
            .map_err(stage)?;
            Ok((d, total.into_inner()))
        };
        Ok([run(PairSearch::Standard)?, run(PairSearch::Every)?])
    })
    .unwrap();
    assert!(tried_pairs(&standard));
    assert!(
        screened < all,
        "the screen fitted {screened} candidates, every pair {all}"
    );
    assert_eq!(first(&standard, 5), first(&every, 5));
}
