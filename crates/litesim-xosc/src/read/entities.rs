//! `Entities`: vehicles, pedestrians and misc objects (inline or from a
//! catalog), their controllers, entity selections; and catalog resolution.

use super::{Cx, R, at, list, next, open, read_text};
use crate::model::*;
use litesim_map::xml::{Node, Tree};
use std::path::PathBuf;

pub(super) fn entities(cx: &mut Cx<'_>, n: Node<'_, '_>, sc: &mut Scenario) -> R<()> {
    cx.children(n, &["ScenarioObject", "EntitySelection"])?;
    for o in n.elements() {
        let name = cx.req(o, "name")?;
        if sc.entities.iter().any(|e| e.name == name)
            || sc.selections.iter().any(|(s, _)| *s == name)
        {
            return Err(cx.err(o, format!("entity '{name}' is declared twice")));
        }
        if o.name() == "EntitySelection" {
            cx.attrs(o, &["name"])?;
            cx.children(o, &["Members"])?;
            let m = cx.child(o, "Members")?;
            cx.children(m, &["EntityRef", "ByType"])?;
            let mut members = Vec::new();
            for e in m.elements() {
                if e.name() == "ByType" {
                    return Err(cx.err(e, "an EntitySelection by type (ByType) is not supported: list its members with EntityRef"));
                }
                cx.attrs(e, &["entityRef"])?;
                members.push(cx.req(e, "entityRef")?);
            }
            sc.selections.push((name, members));
            continue;
        }
        let e = cx.within(o, |cx| scenario_object(cx, o, name))?;
        sc.entities.push(e);
    }
    Ok(())
}

fn scenario_object(cx: &mut Cx<'_>, o: Node<'_, '_>, name: String) -> R<Entity> {
    cx.attrs(o, &["name"])?;
    cx.children(
        o,
        &[
            "CatalogReference",
            "Vehicle",
            "Pedestrian",
            "MiscObject",
            "ExternalObjectReference",
            "ObjectController",
        ],
    )?;
    let body = o
        .elements()
        .find(|c| c.name() != "ObjectController")
        .ok_or_else(|| {
            cx.err(
                o,
                "<ScenarioObject> needs one of CatalogReference, Vehicle, Pedestrian or MiscObject",
            )
        })?;
    let (kind, bbox) = match body.name() {
        "CatalogReference" => with_entry(
            cx,
            body,
            "entity",
            &["Vehicle", "Pedestrian", "MiscObject"],
            |cx, e| cx.within(e, |cx| object_body(cx, e)),
        )?,
        "ExternalObjectReference" => {
            return Err(cx.err(body, "ExternalObjectReference (an object of the road network) is not supported: declare the object as a MiscObject"));
        }
        _ => cx.within(body, |cx| scoped(cx, body, |cx| object_body(cx, body)))?,
    };
    let mut controller = None;
    let controllers: Vec<_> = o
        .elements()
        .filter(|c| c.name() == "ObjectController")
        .collect();
    if controllers.len() > 1 {
        return Err(cx.err(
            controllers[1],
            "several ObjectControllers on one entity are not supported (one is)",
        ));
    }
    if let Some(c) = controllers.first() {
        if matches!(kind, EntityKind::MiscObject { .. }) {
            return Err(cx.err(*c, "a MiscObject is never controlled"));
        }
        controller = Some(cx.within(*c, |cx| object_controller(cx, *c))?);
    }
    Ok(Entity {
        name,
        kind,
        bbox,
        controller,
        at: at(cx, o),
    })
}

/// `ObjectController`: an inline `Controller` or a catalog reference.
pub(super) fn object_controller(cx: &mut Cx<'_>, c: Node<'_, '_>) -> R<Controller> {
    cx.attrs(c, &["name"])?;
    let inner = cx.choice(c, &["Controller", "CatalogReference"])?;
    if inner.name() == "CatalogReference" {
        return with_entry(cx, inner, "ControllerCatalog", &["Controller"], |cx, e| {
            cx.within(e, |cx| controller(cx, e))
        });
    }
    cx.within(inner, |cx| scoped(cx, inner, |cx| controller(cx, inner)))
}

/// A `Controller` (its parameters in scope).
pub(super) fn controller(cx: &mut Cx<'_>, c: Node<'_, '_>) -> R<Controller> {
    cx.attrs(c, &["name", "controllerType"])?;
    cx.children(c, &["ParameterDeclarations", "Properties"])?;
    let name = cx.req(c, "name")?;
    cx.enumer(
        c,
        "controllerType",
        &[
            "lateral",
            "longitudinal",
            "lighting",
            "animation",
            "movement",
            "appearance",
            "all",
        ],
    )?;
    let props = properties(cx, c)?;
    // esmini's convention: a controller named ExternalController, or one
    // whose esminiController property says so, hands the entity to a
    // driver outside the player.
    let external = name == "ExternalController"
        || props.iter().any(|(k, v)| {
            (k == "esminiController" || k == "external")
                && (v == "ExternalController" || v == "true")
        });
    Ok(Controller {
        name,
        external,
        properties: props,
    })
}

/// Runs `f` on an inline catalogable element with its own
/// `ParameterDeclarations` in scope (a catalog entry gets them from
/// [`with_entry`], with the reference's assignments).
pub(super) fn scoped<T>(
    cx: &mut Cx<'_>,
    e: Node<'_, '_>,
    f: impl FnOnce(&mut Cx<'_>) -> R<T>,
) -> R<T> {
    let decls = cx.opt_child(e, "ParameterDeclarations")?;
    cx.push_scope(decls, &[])?;
    let r = f(cx);
    cx.pop_scope();
    r
}

/// `Properties/Property name value` (files are by contract; kept as text).
fn properties(cx: &Cx<'_>, n: Node<'_, '_>) -> R<Vec<(String, String)>> {
    let Some(p) = cx.opt_child(n, "Properties")? else {
        return Ok(Vec::new());
    };
    cx.children(p, &["Property", "File", "CustomContent"])?;
    let mut out = Vec::new();
    for q in p.elements().filter(|q| q.name() == "Property") {
        cx.attrs(q, &["name", "value"])?;
        out.push((cx.req(q, "name")?, cx.req(q, "value")?));
    }
    Ok(out)
}

/// A `Vehicle`, `Pedestrian` or `MiscObject` (its parameters in scope).
fn object_body(cx: &mut Cx<'_>, e: Node<'_, '_>) -> R<(EntityKind, [f64; 6])> {
    match e.name() {
        "Vehicle" => vehicle(cx, e),
        "Pedestrian" => {
            cx.attrs(
                e,
                &[
                    "name",
                    "model",
                    "model3d",
                    "mass",
                    "pedestrianCategory",
                    "role",
                ],
            )?;
            cx.children(e, &["ParameterDeclarations", "BoundingBox", "Properties"])?;
            let category = cx.req_enum(
                e,
                "pedestrianCategory",
                &["pedestrian", "wheelchair", "animal"],
            )?;
            properties(cx, e)?;
            Ok((
                EntityKind::Pedestrian {
                    category,
                    mass: cx.non_neg(e, "mass")?,
                },
                bounding_box(cx, e)?,
            ))
        }
        _ => {
            cx.attrs(e, &["name", "mass", "miscObjectCategory", "model3d"])?;
            cx.children(e, &["ParameterDeclarations", "BoundingBox", "Properties"])?;
            let category = cx.req_enum(
                e,
                "miscObjectCategory",
                &[
                    "barrier",
                    "building",
                    "crosswalk",
                    "gantry",
                    "none",
                    "obstacle",
                    "parkingSpace",
                    "patch",
                    "pole",
                    "railing",
                    "roadMark",
                    "soundBarrier",
                    "streetLamp",
                    "trafficIsland",
                    "tree",
                    "vegetation",
                    "wind",
                ],
            )?;
            properties(cx, e)?;
            Ok((
                EntityKind::MiscObject {
                    category,
                    mass: cx.non_neg(e, "mass")?,
                },
                bounding_box(cx, e)?,
            ))
        }
    }
}

/// `BoundingBox`: centre x, y, z and length, width, height (m).
fn bounding_box(cx: &Cx<'_>, e: Node<'_, '_>) -> R<[f64; 6]> {
    let b = cx.child(e, "BoundingBox")?;
    cx.attrs(b, &[])?;
    cx.children(b, &["Center", "Dimensions"])?;
    let c = cx.child(b, "Center")?;
    cx.attrs(c, &["x", "y", "z"])?;
    let d = cx.child(b, "Dimensions")?;
    cx.attrs(d, &["width", "length", "height"])?;
    Ok([
        cx.num(c, "x")?,
        cx.num(c, "y")?,
        cx.num(c, "z")?,
        cx.non_neg(d, "length")?,
        cx.non_neg(d, "width")?,
        cx.non_neg(d, "height")?,
    ])
}

/// A `Vehicle` (its parameters in scope).
fn vehicle(cx: &mut Cx<'_>, e: Node<'_, '_>) -> R<(EntityKind, [f64; 6])> {
    cx.attrs(e, &["name", "vehicleCategory", "role", "mass", "model3d"])?;
    cx.children(
        e,
        &[
            "ParameterDeclarations",
            "BoundingBox",
            "Performance",
            "Axles",
            "Properties",
            "TrailerHitch",
            "TrailerCoupler",
            "Trailer",
        ],
    )?;
    let category = cx.req_enum(
        e,
        "vehicleCategory",
        &[
            "bicycle",
            "bus",
            "car",
            "motorbike",
            "semitrailer",
            "trailer",
            "train",
            "tram",
            "truck",
            "van",
        ],
    )?;
    let p = cx.child(e, "Performance")?;
    cx.attrs(
        p,
        &[
            "maxSpeed",
            "maxAcceleration",
            "maxDeceleration",
            "maxAccelerationRate",
            "maxDecelerationRate",
            "mass",
        ],
    )?;
    let performance = [
        cx.non_neg(p, "maxSpeed")?,
        cx.non_neg(p, "maxAcceleration")?,
        cx.non_neg(p, "maxDeceleration")?,
    ];
    let axles = cx.child(e, "Axles")?;
    cx.children(axles, &["FrontAxle", "RearAxle", "AdditionalAxle"])?;
    let front_axle = match cx.opt_child(axles, "FrontAxle")? {
        Some(a) => Some(axle(cx, a)?),
        None if cx.version.1 < 3 => {
            return Err(cx.err(axles, "<Axles> needs a <FrontAxle> before OpenSCENARIO 1.3"));
        }
        None => None,
    };
    let rear_axle = axle(cx, cx.child(axles, "RearAxle")?)?;
    let mass = cx.opt_num(e, "mass")?;
    properties(cx, e)?;
    Ok((
        EntityKind::Vehicle {
            category,
            performance,
            front_axle,
            rear_axle,
            mass,
        },
        bounding_box(cx, e)?,
    ))
}

/// An axle: max steering (rad), wheel diameter, track width, position x
/// and z (m).
fn axle(cx: &Cx<'_>, a: Node<'_, '_>) -> R<[f64; 5]> {
    cx.attrs(
        a,
        &[
            "maxSteering",
            "wheelDiameter",
            "trackWidth",
            "positionX",
            "positionZ",
        ],
    )?;
    Ok([
        cx.num(a, "maxSteering")?,
        cx.non_neg(a, "wheelDiameter")?,
        cx.non_neg(a, "trackWidth")?,
        cx.num(a, "positionX")?,
        cx.num(a, "positionZ")?,
    ])
}

/// Resolves a `CatalogReference` (`kind`: the `CatalogLocations` element,
/// or `entity` for the vehicle, pedestrian and misc-object catalogs) to
/// its entry, one of `elems`, and reads it with `f` in the catalog file's
/// own context, its parameters set by the reference's assignments.
pub(super) fn with_entry<T>(
    cx: &mut Cx<'_>,
    r: Node<'_, '_>,
    kind: &str,
    elems: &[&str],
    f: impl FnOnce(&mut Cx<'_>, Node<'_, '_>) -> R<T>,
) -> R<T> {
    cx.attrs(r, &["catalogName", "entryName"])?;
    cx.children(r, &["ParameterAssignments"])?;
    let catalog = cx.req(r, "catalogName")?;
    let entry = cx.req(r, "entryName")?;
    let mut assigned = Vec::new();
    if let Some(a) = cx.opt_child(r, "ParameterAssignments")? {
        cx.children(a, &["ParameterAssignment"])?;
        for p in a.elements() {
            cx.attrs(p, &["parameterRef", "value"])?;
            assigned.push((cx.req(p, "parameterRef")?, cx.req(p, "value")?));
        }
    }
    let kinds: Vec<&str> = if kind == "entity" {
        vec!["VehicleCatalog", "PedestrianCatalog", "MiscObjectCatalog"]
    } else {
        vec![kind]
    };
    let dirs: Vec<PathBuf> = kinds
        .iter()
        .filter_map(|k| cx.catalog_dirs.get(*k).cloned())
        .collect();
    if dirs.is_empty() {
        return Err(cx.err(
            r,
            format!(
                "catalog '{catalog}' is referenced but CatalogLocations names no {}",
                list(&kinds)
            ),
        ));
    }
    find_entry(cx, r, (&catalog, &entry, elems), &assigned, &dirs, f)
}

/// The `.xosc` files of a catalog directory, sorted (the same choice on
/// every machine).
fn catalog_files(cx: &mut Cx<'_>, r: Node<'_, '_>, dir: &PathBuf) -> R<Vec<PathBuf>> {
    if let Some(f) = cx.catalog_files.get(dir) {
        return Ok(f.iter().map(|(_, p)| p.clone()).collect());
    }
    let rd = std::fs::read_dir(dir).map_err(|e| {
        cx.err(
            r,
            format!(
                "the catalog directory {} cannot be read: {e}",
                dir.display()
            ),
        )
    })?;
    let mut files: Vec<PathBuf> = rd
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "xosc"))
        .collect();
    files.sort();
    cx.catalog_files.insert(
        dir.clone(),
        files.iter().map(|p| (String::new(), p.clone())).collect(),
    );
    Ok(files)
}

/// Finds entry `entry` of catalog `catalog` in `dirs` and reads it with `f`.
fn find_entry<T>(
    cx: &mut Cx<'_>,
    r: Node<'_, '_>,
    (catalog, entry, elems): (&str, &str, &[&str]),
    assigned: &[(String, String)],
    dirs: &[PathBuf],
    f: impl FnOnce(&mut Cx<'_>, Node<'_, '_>) -> R<T>,
) -> R<T> {
    let key = format!("{catalog}/{entry}");
    if cx.resolving.contains(&key) {
        return Err(cx.err(
            r,
            format!(
                "catalog entry {key} refers to itself (through {})",
                cx.resolving.join(" → ")
            ),
        ));
    }
    let mut tried = Vec::new();
    for dir in dirs {
        for file in catalog_files(cx, r, dir)? {
            tried.push(file.display().to_string());
            let text = read_text(&file, "catalog")?;
            let mut sub = Cx::new(&text, &file);
            sub.catalog_dirs = cx.catalog_dirs.clone();
            sub.resolving = cx.resolving.clone();
            sub.resolving.push(key.clone());
            let (mut stream, root) = open(&sub)?;
            if root.root().name() != "OpenSCENARIO" {
                continue;
            }
            let mut tree = Tree::new(&text);
            while next(&sub, &mut stream, &mut tree)? {
                let c = tree.root();
                if c.name() == "FileHeader" {
                    if let (Some(_), Some(m)) =
                        (sub.opt_int(c, "revMajor")?, sub.opt_int(c, "revMinor")?)
                    {
                        sub.version = (1, m.clamp(0, 3) as u32);
                    }
                    continue;
                }
                if c.name() != "Catalog" || c.attribute("name") != Some(catalog) {
                    continue;
                }
                let found = c.elements().find(|e| e.attribute("name") == Some(entry));
                let Some(e) = found else {
                    let have: Vec<&str> =
                        c.elements().filter_map(|e| e.attribute("name")).collect();
                    return Err(cx.err(
                        r,
                        format!(
                            "catalog '{catalog}' ({}) has no entry '{entry}' (it has {})",
                            file.display(),
                            if have.is_empty() {
                                "none".to_string()
                            } else {
                                have.join(", ")
                            }
                        ),
                    ));
                };
                if !elems.contains(&e.name()) {
                    return Err(cx.err(
                        r,
                        format!(
                            "catalog entry {key} is a <{}>, where {} was expected",
                            e.name(),
                            list(elems)
                        ),
                    ));
                }
                sub.path = vec!["OpenSCENARIO".into(), format!("Catalog[{catalog}]")];
                // The entry's top-level parameters, the reference's
                // assignments replacing their defaults.
                let decls = sub.opt_child(e, "ParameterDeclarations")?;
                sub.push_scope(decls, assigned)?;
                let v = f(&mut sub, e);
                sub.pop_scope();
                return v;
            }
        }
    }
    Err(cx.err(
        r,
        format!(
            "no catalog named '{catalog}' in {} (files read: {})",
            dirs.iter()
                .map(|d| d.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
            if tried.is_empty() {
                "none".to_string()
            } else {
                tried.join(", ")
            }
        ),
    ))
}
