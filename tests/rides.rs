//! The checked-in ride campaign is exactly what the simulator writes from data/lab_bike.toml
//! (so it can be regenerated and nobody edits it by hand), and it is what issue 5 asks for.

use std::path::Path;

#[test]
fn the_ride_campaign_in_data_is_the_generators() {
    let data = Path::new(env!("CARGO_MANIFEST_DIR")).join("data");
    let bike = bikeproc::inertia::bike::LabBike::load(&data.join("lab_bike.toml")).unwrap();
    let files = bikeproc::sim::campaign::lab_rides(&bike).unwrap();
    let rides = files
        .iter()
        .filter(|(p, _)| {
            p.extension().is_some_and(|e| e == "log") && !p.to_string_lossy().ends_with("_cal.log")
        })
        .count();
    assert!(rides >= 16, "{rides} rides");
    for (rel, text) in &files {
        let on_disk = std::fs::read_to_string(data.join(rel)).unwrap_or_default();
        assert!(
            &on_disk == text,
            "data/{} differs from the generator's: run `bikeproc simulate rides --out data`",
            rel.display()
        );
    }
    // The speeds the lab wrote down cover 2.5–6.5 m/s.
    let manifest = std::fs::read_to_string(data.join("rides.toml")).unwrap();
    let speeds: Vec<f64> = manifest
        .lines()
        .filter_map(|l| l.strip_prefix("noted_speed_mps = "))
        .map(|v| v.parse().unwrap())
        .collect();
    assert_eq!(speeds.len(), rides);
    assert!(speeds.iter().all(|v| (2.5..=6.8).contains(v)));
}
