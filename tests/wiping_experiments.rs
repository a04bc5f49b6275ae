//! The wiping experiments (issue 9): the shipped Universal Controller, DR
//! gains and UC-MLP (policies/wiping/), a reduced Table 3 and a reduced
//! higher-dimension study.

use std::path::PathBuf;

use diffosi::experiments::wiping::{self, Controllers, Uc, METHODS};
use diffosi::experiments::wiping_dims;
use diffosi::osi::mlp::MuMlp;
use diffosi::tasks::wiping::{Wiping, GAINS_LOWER, GAINS_UPPER};

fn shipped(name: &str) -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
        .join("policies/wiping")
        .join(name)
}

fn dr_gains() -> diffosi::control::admittance::Gains {
    let text = std::fs::read_to_string(shipped("dr.json")).unwrap();
    let v: serde_json::Value = serde_json::from_str(&text).unwrap();
    diffosi::control::admittance::Gains {
        k_tau: v["k_tau"].as_f64().unwrap(),
        k_xi: v["k_xi"].as_f64().unwrap(),
    }
}

#[test]
fn the_shipped_uc_maps_mu_into_the_gains_box_and_round_trips() {
    let uc = Uc::load(&shipped("uc.json")).unwrap();
    assert_eq!(uc.net.sizes(), [2, 512, 512, 2]);
    assert_eq!(uc.net.activation(), diffosi::nn::Activation::Relu);
    for mu in [
        [1.0, 1.0],
        [100.0, 1.0],
        [50.0, 50.0],
        [1.0, 100.0],
        [100.0, 100.0],
    ] {
        let g = uc.gains(&mu);
        assert!(g.k_tau >= GAINS_LOWER.k_tau * 0.999 && g.k_tau <= GAINS_UPPER.k_tau * 1.001);
        assert!(g.k_xi >= GAINS_LOWER.k_xi * 0.999 && g.k_xi <= GAINS_UPPER.k_xi * 1.001);
    }
    let path = std::env::temp_dir().join(format!("uc-{}.json", std::process::id()));
    uc.save(&path).unwrap();
    assert_eq!(Uc::load(&path).unwrap(), uc);
    std::fs::write(&path, "{\"format\": \"other\"}").unwrap();
    assert!(Uc::load(&path).is_err());
    std::fs::remove_file(&path).ok();
}

#[test]
fn a_reduced_table3_ranks_diffosi_with_the_oracle_and_is_deterministic() {
    let task = Wiping::new();
    let uc = Uc::load(&shipped("uc.json")).unwrap();
    let mlp = MuMlp::load(&shipped("uc-mlp.json")).unwrap();
    let controllers = Controllers {
        uc: &uc,
        dr: dr_gains(),
        mlp: &mlp,
        cmaes_budget: 40,
    };
    let run = || wiping::table3(&task, &controllers, (2, 5), 2, &|_| {}).unwrap();
    let runs = run();
    let rows = wiping::summarise(&runs);
    assert_eq!(rows.len(), METHODS.len());
    let row = |label: &str| rows.iter().find(|r| r.label == label).unwrap();
    assert_eq!(row("UC-Oracle").mae.unwrap().0, 0.0);
    assert!(row("DR").mae.is_none());
    let diffosi = row("UC-DiffOSI");
    assert!(diffosi.mare.unwrap().0 < 1e-6, "{:?}", diffosi.mare);
    assert!((diffosi.metric.0 - row("UC-Oracle").metric.0).abs() < 1e-6);
    assert!(row("UC-CMA-ES").mae.unwrap().0 > diffosi.mae.unwrap().0);
    let json = |runs| {
        serde_json::to_string(&wiping::json(runs, serde_json::Value::Null)["methods"]).unwrap()
    };
    assert_eq!(json(&runs), json(&run()));
}

#[test]
fn diffosi_needs_fewer_evaluations_than_cma_es_in_2d_and_3d() {
    let dims =
        wiping_dims::study(&[2, 3], (1, 11), (&[1, 2, 4, 8], &[10, 40, 160]), &|| {}).unwrap();
    for (d, s) in dims.iter().zip(wiping_dims::summarise(&dims)) {
        let last = d.runs[0].diffosi.last().unwrap();
        println!(
            "{}-D: DiffOSI relative error {:.1e} after {} evaluations; CMA-ES {:.2e} (abs) after {}; DiffOSI reached it in {:?}",
            d.dimension, last.rel_error, last.evaluations, s.cmaes_final, s.cmaes_evaluations, s.diffosi_evaluations
        );
        assert!(
            last.rel_error < 1e-3,
            "{}-D: {}",
            d.dimension,
            last.rel_error
        );
        let needed = s
            .diffosi_evaluations
            .expect("DiffOSI reaches CMA-ES's error");
        assert!(
            needed < s.cmaes_evaluations,
            "{needed} vs {}",
            s.cmaes_evaluations
        );
    }
}
