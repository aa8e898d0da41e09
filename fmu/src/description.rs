//! The FMI 2.0 model description (`modelDescription.xml`, FMI 2.0.4 standard, section 2.2)
//! written from the variable table of `variables`.

use crate::variables::{Causality, Type, Var, UNITS};

/// What the model description says about an FMU besides its variables.
pub struct Header<'a> {
    pub model_name: &'a str,
    pub model_identifier: &'a str,
    pub guid: &'a str,
    pub description: &'a str,
    /// Default experiment: stop time and communication step, s.
    pub stop_time_s: f64,
    pub step_s: f64,
}

/// XML text with the five reserved characters escaped.
fn esc(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
        .replace('\'', "&apos;")
}

/// A number in its shortest round-trip form (the table's starts and ranges are finite).
fn num(x: f64) -> String {
    format!("{x:?}")
}

fn unit_definitions(vars: &[Var]) -> String {
    let mut out = String::from("  <UnitDefinitions>\n");
    for (name, exps, factor) in UNITS {
        if !vars.iter().any(|v| v.unit == Some(name)) {
            continue;
        }
        let mut base = String::new();
        for (key, e) in ["kg", "m", "s", "rad"].iter().zip(exps) {
            if e != 0 {
                base += &format!(" {key}=\"{e}\"");
            }
        }
        if factor != 1.0 {
            base += &format!(" factor=\"{}\"", num(factor));
        }
        out += &format!(
            "    <Unit name=\"{}\">\n      <BaseUnit{base}/>\n    </Unit>\n",
            esc(name)
        );
    }
    out + "  </UnitDefinitions>\n"
}

fn scalar_variable(k: usize, v: &Var) -> String {
    let (causality, variability, initial) = match (v.causality, v.ty) {
        (Causality::Parameter, _) => ("parameter", "fixed", Some("exact")),
        (Causality::Input, Type::Real) => ("input", "continuous", None),
        (Causality::Input, _) => ("input", "discrete", None),
        (Causality::Output, Type::Real) => ("output", "continuous", Some("calculated")),
        (Causality::Output, _) => ("output", "discrete", Some("calculated")),
    };
    let mut attrs = String::new();
    if let Some(u) = v.unit {
        attrs += &format!(" unit=\"{}\"", esc(u));
    }
    if let Some([lo, hi]) = v.range {
        let (lo, hi) = match v.ty {
            Type::Integer => (format!("{}", lo as i64), format!("{}", hi as i64)),
            _ => (num(lo), num(hi)),
        };
        attrs += &format!(" min=\"{lo}\" max=\"{hi}\"");
    }
    if v.causality != Causality::Output {
        let start = match v.ty {
            Type::Real => num(v.start),
            Type::Integer => format!("{}", v.start as i64),
            Type::Boolean => (v.start != 0.0).to_string(),
        };
        attrs += &format!(" start=\"{start}\"");
    }
    let element = match v.ty {
        Type::Real => "Real",
        Type::Integer => "Integer",
        Type::Boolean => "Boolean",
    };
    let initial = initial.map_or(String::new(), |i| format!(" initial=\"{i}\""));
    format!(
        "    <!-- {index} -->\n    <ScalarVariable name=\"{}\" valueReference=\"{k}\" \
         description=\"{}\" causality=\"{causality}\" variability=\"{variability}\"{initial}>\n      \
         <{element}{attrs}/>\n    </ScalarVariable>\n",
        esc(&v.name),
        esc(&v.description),
        index = k + 1,
    )
}

/// The model description of a co-simulation FMU with these variables.
pub fn model_description(h: &Header, vars: &[Var]) -> String {
    let mut out = format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<fmiModelDescription fmiVersion=\"2.0\" \
         modelName=\"{}\" guid=\"{}\" description=\"{}\" generationTool=\"beltwin {}\" \
         variableNamingConvention=\"flat\" numberOfEventIndicators=\"0\">\n  <CoSimulation \
         modelIdentifier=\"{}\" canHandleVariableCommunicationStepSize=\"true\" \
         canGetAndSetFMUstate=\"true\" canNotUseMemoryManagementFunctions=\"true\"/>\n",
        esc(h.model_name),
        esc(h.guid),
        esc(h.description),
        env!("CARGO_PKG_VERSION"),
        esc(h.model_identifier),
    );
    out += &unit_definitions(vars);
    out += &format!(
        "  <DefaultExperiment startTime=\"0.0\" stopTime=\"{}\" stepSize=\"{}\"/>\n",
        num(h.stop_time_s),
        num(h.step_s)
    );
    out += "  <ModelVariables>\n";
    for (k, v) in vars.iter().enumerate() {
        out += &scalar_variable(k, v);
    }
    out += "  </ModelVariables>\n  <ModelStructure>\n    <Outputs>\n";
    let outputs: Vec<usize> = (0..vars.len())
        .filter(|&k| vars[k].causality == Causality::Output)
        .collect();
    for k in &outputs {
        out += &format!("      <Unknown index=\"{}\"/>\n", k + 1);
    }
    out += "    </Outputs>\n    <InitialUnknowns>\n";
    for k in &outputs {
        out += &format!("      <Unknown index=\"{}\"/>\n", k + 1);
    }
    out + "    </InitialUnknowns>\n  </ModelStructure>\n</fmiModelDescription>\n"
}
