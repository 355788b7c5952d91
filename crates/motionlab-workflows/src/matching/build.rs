//! Building the `[matching]` workflow: the model, the user takes (continuous or explicit
//! windows, each continuous take's detector built with its own count) and the stages.

use motionlab_core::{Error, ErrorKind, Result};
use motionlab_experiment::spec::StageSpec;
use motionlab_experiment::toml_paths::KeyPath;
use motionlab_experiment::workflow::{BuildContext, WorkflowPlugin, build_evaluators, sanitize};
use motionlab_experiment::{BuiltDataset, Datasets, build_stage};

use super::{MatchingSection, MatchingWorkflow, Take, TakeKind};

impl WorkflowPlugin for MatchingWorkflow {
    type Section = MatchingSection;
    fn build(section: MatchingSection, cx: &BuildContext<'_>) -> Result<Self> {
        // Yabe & Tanaka's features are 3-D marker distances and directions.
        cx.require_3d_unless("the matching workflow", false, &cx.root)?;
        let (source, combo, root) = (cx.source, cx.combo, &cx.root);
        let locate = |e: Error, key: &str| cx.locate(e, root.join_field(key));
        if section.peaks_per_repetition == 0 {
            return Err(locate(
                Error::new(
                    ErrorKind::OutOfRange,
                    "expected at least one velocity peak per repetition, found 0",
                ),
                "peaks_per_repetition",
            ));
        }
        if let Some(points) = &section.points {
            check_point_list(points).map_err(|e| locate(e, "points"))?;
            if let Some(pm) = &section.path_markers
                && let Some(m) = pm.iter().find(|m| !points.contains(m))
            {
                return Err(locate(
                    Error::new(
                        ErrorKind::UnknownName,
                        format!("path marker {m:?} is not among the matched `points`"),
                    ),
                    "path_markers",
                ));
            }
        }
        let model = find_model(&section.model, cx.data).map_err(|e| locate(e, "model"))?;
        let matcher = build_stage(
            source,
            combo,
            &section.matcher,
            &root.key("matcher"),
            motionlab_match::build_matcher,
        )?;
        let synchroniser = build_stage(
            source,
            combo,
            &section.synchroniser,
            &root.key("synchroniser"),
            motionlab_match::build_synchroniser,
        )?;
        let matcher_points = stage_points(&section.matcher);
        let evaluators = build_evaluators(source, combo, motionlab_match::matching_results())?;
        let takes = build_takes(cx, &section, model)?;
        if takes.is_empty() {
            return Err(locate(
                Error::new(
                    ErrorKind::MissingKey,
                    "no user take: every [[dataset]] but the model is a take (tag it `repetitions = \"N\"`, or `take = \"<name>\"` for one repetition per dataset)",
                ),
                "model",
            ));
        }
        Ok(MatchingWorkflow {
            section,
            model,
            takes,
            matcher,
            matcher_points,
            synchroniser,
            evaluators,
            locator: cx.locator(),
        })
    }
}

motionlab_experiment::register_workflow!(MatchingWorkflow, "matching");

fn check_point_list(points: &[String]) -> Result<()> {
    if points.is_empty() {
        return Err(Error::new(
            ErrorKind::InvalidParameter,
            "expected at least one marker name, found an empty list",
        ));
    }
    for (i, p) in points.iter().enumerate() {
        if points[..i].contains(p) {
            return Err(Error::new(
                ErrorKind::DuplicateName,
                format!("marker {p:?} is listed twice"),
            ));
        }
    }
    Ok(())
}

/// The points a stage's parameters name (`points = [...]` or `marker = "..."`), if any.
fn stage_points(spec: &StageSpec) -> Option<Vec<String>> {
    match (spec.params.get("points"), spec.params.get("marker")) {
        (Some(toml::Value::Array(a)), _) => {
            a.iter().map(|v| v.as_str().map(str::to_string)).collect()
        }
        (_, Some(toml::Value::String(m))) => Some(vec![m.clone()]),
        _ => None,
    }
}

pub(crate) fn dataset_label(d: &BuiltDataset) -> String {
    d.spec.name.clone().unwrap_or_else(|| {
        (0..d.files.len()).map(|k| d.sequence_name(k)).collect::<Vec<_>>().join(", ")
    })
}

pub(crate) fn find_model(name: &str, data: &Datasets) -> Result<usize> {
    let hits: Vec<&BuiltDataset> = data
        .datasets
        .iter()
        .filter(|d| {
            d.spec.name.as_deref() == Some(name)
                || (d.spec.name.is_none() && d.files.len() == 1 && d.sequence_name(0) == name)
        })
        .collect();
    match hits.as_slice() {
        [d] if d.files.len() == 1 => Ok(d.index),
        [d] => Err(Error::new(
            ErrorKind::InvalidParameter,
            format!(
                "the model dataset {name:?} resolves to {} files; expected exactly one (one basic motion)",
                d.files.len()
            ),
        )),
        [] => Err(Error::new(
            ErrorKind::UnknownName,
            format!(
                "no dataset named {name:?}; the datasets are: {}",
                data.datasets
                    .iter()
                    .map(|d| format!("{:?}", dataset_label(d)))
                    .collect::<Vec<_>>()
                    .join(", ")
            ),
        )),
        _ => Err(Error::new(
            ErrorKind::DuplicateName,
            format!("{} datasets are named {name:?}; name the model uniquely", hits.len()),
        )),
    }
}

/// Every user take, its detector built with its own count (so validation checks them all),
/// each with a unique item id.
fn build_takes(
    cx: &BuildContext<'_>,
    section: &MatchingSection,
    model: usize,
) -> Result<Vec<Take>> {
    let detector_path = cx.root.key("point_detector");
    if let Some(spec) = &section.point_detector
        && spec.params.contains_key("count")
    {
        return Err(cx.locate(
            Error::new(
                ErrorKind::InvalidParameter,
                "`count` is set per take by the workflow: tag the take's dataset `repetitions = \"N\"` or set `[matching.repetitions]`",
            ),
            detector_path.key("count"),
        ));
    }
    let mut takes: Vec<Take> = Vec::new();
    let mut used_overrides: Vec<&str> = Vec::new();
    for d in cx.data.datasets.iter().filter(|d| d.index != model) {
        if let Some(take) = d.tag("take") {
            add_explicit_member(cx, d, take, &mut takes)?;
            continue;
        }
        for file in 0..d.files.len() {
            let name = d.sequence_name(file);
            let count = repetitions_of(cx, section, d, &name, &mut used_overrides)?;
            let Some(spec) = &section.point_detector else {
                return Err(cx.locate(
                    Error::new(
                        ErrorKind::MissingKey,
                        format!(
                            "take {name:?} is continuous, so [matching] needs a `point_detector`"
                        ),
                    ),
                    &cx.root,
                ));
            };
            let mut with_count = spec.clone();
            with_count.params.insert(
                "count".into(),
                toml::Value::Integer((count * section.peaks_per_repetition) as i64),
            );
            let detector = build_stage(
                cx.source,
                cx.combo,
                &with_count,
                &detector_path,
                motionlab_match::build_point_detector,
            )?;
            if takes.iter().any(|t| t.name == name) {
                return Err(cx.locate(
                    Error::new(
                        ErrorKind::DuplicateName,
                        format!("two takes are named {name:?}; give the datasets distinct `name`s"),
                    ),
                    dataset_path(d),
                ));
            }
            takes.push(Take {
                id: String::new(),
                name,
                kind: TakeKind::Continuous { dataset: d.index, file, count, detector },
            });
        }
    }
    if let Some(unused) = section.repetitions.keys().find(|k| !used_overrides.contains(&k.as_str()))
    {
        let names: Vec<String> = takes
            .iter()
            .filter(|t| matches!(t.kind, TakeKind::Continuous { .. }))
            .map(|t| format!("{:?}", t.name))
            .collect();
        return Err(cx.locate(
            Error::new(
                ErrorKind::UnknownName,
                format!(
                    "{unused:?} names no continuous take; the continuous takes are: {}",
                    names.join(", ")
                ),
            ),
            cx.root.key("repetitions").key(unused),
        ));
    }
    assign_item_ids(&mut takes);
    Ok(takes)
}

/// `[[dataset]]` number `d.index` of the experiment.
fn dataset_path(d: &BuiltDataset) -> KeyPath {
    KeyPath::default().key("dataset").index(d.index)
}

/// A dataset tagged `take = "<name>"`: each of its files one repetition of that explicit take
/// (added to it, or a new take), its tags checked.
fn add_explicit_member(
    cx: &BuildContext<'_>,
    d: &BuiltDataset,
    take: &str,
    takes: &mut Vec<Take>,
) -> Result<()> {
    let at_tag = |key: &str, e: Error| cx.locate(e, dataset_path(d).key("tags").key(key));
    if d.tag("repetitions").is_some() {
        return Err(at_tag(
            "repetitions",
            Error::new(
                ErrorKind::InvalidParameter,
                "a dataset is either one repetition of an explicit take (`take`) or a continuous take (`repetitions`), not both",
            ),
        ));
    }
    if let Some(g) = d.tag("group")
        && !["a", "b", "c"].contains(&g)
    {
        return Err(at_tag(
            "group",
            Error::new(
                ErrorKind::InvalidParameter,
                format!(
                    "group {g:?}: expected \"a\" (close), \"b\" (timing-shifted) or \"c\" (wrong)"
                ),
            ),
        ));
    }
    let members: Vec<(usize, usize)> = (0..d.files.len()).map(|f| (d.index, f)).collect();
    match takes.iter_mut().find(|t| t.name == take) {
        Some(Take { kind: TakeKind::Explicit { members: m }, .. }) => m.extend(members),
        Some(_) => {
            return Err(at_tag(
                "take",
                Error::new(
                    ErrorKind::DuplicateName,
                    format!("take {take:?} is also the name of a continuous take"),
                ),
            ));
        }
        None => takes.push(Take {
            id: String::new(),
            name: take.to_string(),
            kind: TakeKind::Explicit { members },
        }),
    }
    Ok(())
}

/// The number of repetitions `N` of the continuous take `name` (a file of `d`): from
/// `[matching.repetitions]` (noted in `used_overrides`), else from the dataset's tag.
fn repetitions_of<'s>(
    cx: &BuildContext<'_>,
    section: &'s MatchingSection,
    d: &BuiltDataset,
    name: &str,
    used_overrides: &mut Vec<&'s str>,
) -> Result<usize> {
    match (section.repetitions.get_key_value(name), d.tag("repetitions")) {
        (Some((key, &n)), _) => {
            used_overrides.push(key.as_str());
            if n == 0 {
                return Err(cx.locate(Error::new(ErrorKind::OutOfRange, "expected at least one repetition, found 0"), cx.root.key("repetitions").key(name)));
            }
            Ok(n)
        }
        (None, Some(text)) => match text.trim().parse::<usize>() {
            Ok(n) if n >= 1 => Ok(n),
            _ => Err(cx.locate(
                Error::new(ErrorKind::WrongType, format!("repetitions = {text:?}: expected a whole number of repetitions >= 1")),
                dataset_path(d).key("tags").key("repetitions"),
            )),
        },
        (None, None) => Err(cx.locate(
            Error::new(
                ErrorKind::MissingKey,
                format!(
                    "dataset {:?} is a user take but says neither how many repetitions it holds (tag `repetitions = \"N\"` or `[matching.repetitions]`) nor that it is one repetition of an explicit take (tag `take = \"<name>\"`)",
                    dataset_label(d)
                ),
            ),
            dataset_path(d),
        )),
    }
}

/// Each take's item id: its [`item_id`], made unique with `_2`, `_3`, … in take order.
fn assign_item_ids(takes: &mut [Take]) {
    let mut ids: Vec<String> = Vec::new();
    for t in takes {
        let base = item_id(&t.name);
        let mut id = base.clone();
        let mut k = 2;
        while ids.contains(&id) {
            id = format!("{base}_{k}");
            k += 1;
        }
        ids.push(id.clone());
        t.id = id;
    }
}

/// A file-name-safe id for a take: [`sanitize`]d, runs of `_` collapsed, no `_` at the ends
/// (`jumping jacks (a)(b)(c)` → `jumping_jacks_a_b_c`).
pub(super) fn item_id(name: &str) -> String {
    let safe = sanitize(name);
    let mut id = String::with_capacity(safe.len());
    for c in safe.chars() {
        if !(c == '_' && (id.is_empty() || id.ends_with('_'))) {
            id.push(c);
        }
    }
    let id = id.trim_end_matches('_').to_string();
    if id.is_empty() { "take".into() } else { id }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn item_ids_are_tidy_file_names() {
        assert_eq!(item_id("jumping jacks (a)(b)(c)"), "jumping_jacks_a_b_c");
        assert_eq!(item_id("13_29"), "13_29");
        assert_eq!(item_id("(()) "), "take");
    }
}
