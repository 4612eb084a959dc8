//! Light sampling, BSDF sampling and their MIS combination are three
//! estimators of the same integral: on the Cornell Box they must agree
//! within their error bars, region by region (error bars that allow for
//! the pixels of a 2 × 2 block sharing their paths, `reuse`).

use crate::common;

use common::{assert_blocks_agree_reused, region_mean_reused, render_film, repo_scene, z_score};

#[test]
fn nee_bsdf_and_mis_agree_on_the_cornell_box() {
    let film = "resolution = [32, 32]\nspp = 256\nmax_depth = 6";
    let films: Vec<_> = ["mis", "nee", "bsdf"]
        .iter()
        .map(|s| {
            let scene = repo_scene(
                "scenes/cornell-box.toml",
                film,
                &format!("strategy = \"{s}\""),
            );
            (s, render_film(&scene, 2))
        })
        .collect();
    // 16 blocks × 3 pairs at 4.5σ: a false alarm about once in 3000 runs.
    for i in 0..3 {
        for j in i + 1..3 {
            let what = format!("{} vs {}", films[i].0, films[j].0);
            assert_blocks_agree_reused(&films[i].1, &films[j].1, 4.5, &what);
        }
    }
    let whole: Vec<_> = films
        .iter()
        .map(|f| region_mean_reused(&f.1, 0, 0, 32, 32))
        .collect();
    for i in 0..3 {
        for j in i + 1..3 {
            assert!(z_score(whole[i], whole[j]) < 4.0, "{whole:?}");
        }
    }
    // MIS is about as good as the better strategy everywhere (here light
    // sampling, for diffuse walls and a small light) and far better than the worse.
    let best = whole[1].1.min(whole[2].1);
    assert!(whole[0].1 < 1.05 * best, "{whole:?}");
    assert!(whole[0].1 < 0.5 * whole[2].1, "{whole:?}");
}
