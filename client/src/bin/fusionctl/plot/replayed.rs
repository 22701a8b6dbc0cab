//! A replay output, and its input for the fixes: the JSON-lines file, or a ROS bag.

use super::*;

/// Reads a replay output and (for the fixes) its input.
pub(super) fn from_replay(output: &Path, input: Option<&Path>) -> anyhow::Result<Data> {
    let text = read_text(output, "--input: a replay output (JSON lines) or an MCAP recording")?;
    let mut data = Data::default();
    let mut gated_fixes = HashMap::new();
    // A bag's samples are found by kind and time (their sensor ids are the
    // configuration's, which the plot does not read).
    let mut gated_at = HashMap::new();
    for (i, line) in text.lines().enumerate().filter(|(_, l)| !l.trim().is_empty()) {
        let v: serde_json::Value =
            serde_json::from_str(line).with_context(|| format!("{}:{}", output.display(), i + 1))?;
        let nums = |k: &str| -> Vec<f64> {
            v[k].as_array().map(|a| a.iter().filter_map(|x| x.as_f64()).collect()).unwrap_or_default()
        };
        let t_ns = v["t_ns"].as_u64().unwrap_or(0);
        data.smoothed |= v["smoothed"].as_bool() == Some(true);
        data.estimates.extend(estimate(t_ns, &nums("x"), &nums("P")));
        let (Some(kind), Some(sensor), Some(seq)) =
            (v["kind"].as_str().and_then(kind_of), v["sensor"].as_u64(), v["seq"].as_u64())
        else {
            continue;
        };
        let gated = v["accepted"].as_bool() == Some(false);
        gated_fixes.insert((kind, sensor as u32, seq), gated);
        gated_at.insert((kind, t_ns), gated);
        if let Some(value) = v["nis"].as_f64() {
            let series = data.nis.entry(format!("{} {sensor}", kind.name())).or_insert((dimension(kind), Vec::new()));
            series.1.push(Nis { t: t_ns as f64 * 1e-9, value, gated });
        }
    }
    if let Some(input) = input
        && fusion_shared::ros::is_bag(input)
    {
        data.fixes = bag_fixes(input, &gated_at)?;
    } else if let Some(input) = input {
        let bytes = std::fs::read(input).with_context(|| format!("cannot read {}", input.display()))?;
        anyhow::ensure!(
            !bytes.starts_with(mcap::MAGIC),
            "{}: --samples takes the file that was replayed (JSON lines, or a ROS bag); an MCAP recording carries \
             its samples: give it as --input",
            input.display()
        );
        let text = as_text(input, bytes, "--samples: the JSON-lines file that was replayed")?;
        let samples: Vec<Sample> = text.lines().filter_map(|l| fusion_shared::jsonl::parse_sample(l).ok()).collect();
        // A replay output carries no datum: geodetic fixes are placed about the
        // first one, fusiond's datum when no [datum] table is configured.
        let datum = samples.iter().find_map(|s| match s {
            Sample::Geodetic(g) => fusion_shared::geodesy::Datum::new(g.lat_deg, g.lon_deg, g.height_m).ok(),
            _ => None,
        });
        if datum.is_some() {
            eprintln!(
                "fusionctl: geodetic fixes placed about the first one (fusiond's datum without a [datum] table; a \
                 recording, --input RUN.mcap, carries the datum fusiond used)"
            );
        }
        for s in samples {
            if let Some((east, north)) = fix_of(&s, datum) {
                let fate = Fate::of(gated_fixes.get(&sample_key(&s)).copied());
                data.fixes.push(Fix { east, north, fate });
            }
        }
    }
    Ok(data)
}

/// The fixes of a ROS bag: every `sensor_msgs/NavSatFix` topic's, whether the
/// replay's configuration maps it or not (a GNSS kept out of the filter is the
/// reference a user draws the estimate against). Placed about the bag's first
/// fix, as fusiond places them without a `[datum]`; each one's fate is the
/// replay output's line of a geodetic sample at its stamp, if there is one.
fn bag_fixes(bag: &Path, gated_at: &HashMap<(SampleKind, u64), bool>) -> anyhow::Result<Vec<Fix>> {
    use fusion_shared::ros::{Route, messages::MessageType, read_bag};
    let context = || format!("--samples {}", bag.display());
    // The topics and their types first: the bag's own list.
    let topics = read_bag(bag, &[], |_| {}).with_context(context)?.topics;
    let routes: Vec<Route> = topics
        .iter()
        .filter(|(_, t)| MessageType::from_name(&t.ty) == Some(MessageType::NavSatFix))
        .enumerate()
        .map(|(i, (topic, _))| Route {
            topic: topic.clone(),
            kinds: vec![SampleKind::Geodetic],
            sensor: i as u32,
            name: topic.clone(),
        })
        .collect();
    if routes.is_empty() {
        eprintln!("fusionctl: {} has no sensor_msgs/NavSatFix topic: no fixes to draw", bag.display());
        return Ok(Vec::new());
    }
    let mut samples = Vec::new();
    let summary = read_bag(bag, &routes, |item| {
        if let Ok(s) = item.sample {
            samples.push(s);
        }
    })
    .with_context(context)?;
    if let Some(damage) = &summary.damage {
        eprintln!("fusionctl: {} is damaged ({damage}): the fixes before the damage are drawn", bag.display());
    }
    let datum = samples.iter().find_map(|s| match s {
        Sample::Geodetic(g) => fusion_shared::geodesy::Datum::new(g.lat_deg, g.lon_deg, g.height_m).ok(),
        _ => None,
    });
    let mut fixes = Vec::new();
    for s in &samples {
        if let Some((east, north)) = fix_of(s, datum) {
            fixes.push(Fix { east, north, fate: Fate::of(gated_at.get(&(s.kind(), s.t_ns())).copied()) });
        }
    }
    let topics: Vec<&str> = routes.iter().map(|r| r.topic.as_str()).collect();
    let not_fused = fixes.iter().filter(|f| f.fate == Fate::NotFused).count();
    eprintln!(
        "fusionctl: {} fixes of {} ({} not fused), placed about the first one (fusiond's datum without a [datum] \
         table)",
        fixes.len(),
        topics.join(", "),
        not_fused
    );
    Ok(fixes)
}
