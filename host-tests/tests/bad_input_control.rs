//! The bad-input sweep ([`host_tests::bad_input`]): the PD and the disturbance
//! observer.

use host_tests::bad_input::{finite, re, refused_or, sweep, Kind, Sweep};
use kerf::app::axis::AxisConfig;
use kerf::control::dob::{Dob, DobConfig, DobState};
use kerf::control::pd::{Pd, PdConfig};
use kerf::trajectory::Reference;
use kerf::Real;

// ---------------------------------------------------------------------------------
// control

fn control_sites<T: Real>(s: &mut Sweep, scalar: &str) {
    const M: &str = "control";
    let reference = Reference {
        position: re::<T>(0.01),
        velocity: re::<T>(0.1),
        acceleration: re::<T>(1.0),
    };
    let pd_probe = |pd: Pd<T>| finite([pd.acceleration(&reference, re::<T>(0.0101), T::ZERO)]);
    s.site(
        M,
        "Pd::new(kp_per_s2) + acceleration",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                Pd::<T>::new(&PdConfig {
                    kp_per_s2: v,
                    kd_per_s: 500.0,
                }),
                pd_probe,
            )
        },
    );
    s.site(
        M,
        "Pd::new(kd_per_s) + acceleration",
        scalar,
        Kind::Config,
        |v| {
            refused_or(
                Pd::<T>::new(&PdConfig {
                    kp_per_s2: 6e4,
                    kd_per_s: v,
                }),
                pd_probe,
            )
        },
    );
    s.site(
        M,
        "PdConfig::critically_damped(bandwidth) + Pd::new",
        scalar,
        Kind::Config,
        |v| refused_or(Pd::<T>::new(&PdConfig::critically_damped(v)), pd_probe),
    );
    let pd = Pd::<T>::new(&AxisConfig::LM1247_SLAVE.pd).unwrap();
    for (name, which) in [("reference", 0), ("position", 1), ("velocity", 2)] {
        s.site(
            M,
            &format!("Pd::acceleration({name})"),
            scalar,
            Kind::Kernel,
            |v| {
                let x = re::<T>(v);
                let mut r = reference;
                let (mut position, mut velocity) = (re::<T>(0.01), T::ZERO);
                match which {
                    0 => r.position = x,
                    1 => position = x,
                    _ => velocity = x,
                }
                finite([pd.acceleration(&r, position, velocity)])
            },
        );
    }
    let nominal = AxisConfig::LM1247_SLAVE.dob;
    let dob_probe = |dob: Dob<T>| {
        let mut state = DobState::at(T::ZERO);
        let mut values = Vec::new();
        for k in 0..20 {
            let out = dob.update(&mut state, re::<T>(1.0), re::<T>(1e-3 * k as f64));
            values.extend([
                out.force_n,
                out.disturbance_n,
                dob.applied_acceleration(&out),
            ]);
        }
        finite(values)
    };
    type Edit = fn(&mut DobConfig, f64);
    let edits: [(&str, Edit); 3] = [
        ("nominal_mass_kg", |c, v| c.nominal_mass_kg = v),
        ("bandwidth_rad_s", |c, v| c.bandwidth_rad_s = v),
        ("force_limit_n", |c, v| c.force_limit_n = v),
    ];
    for (field, edit) in edits {
        s.site(
            M,
            &format!("Dob::new({field}) + update"),
            scalar,
            Kind::Config,
            |v| {
                let mut config = nominal;
                edit(&mut config, v);
                refused_or(Dob::<T>::new(&config, 1e-4), dob_probe)
            },
        );
    }
    s.site(M, "Dob::new(ts_s) + update", scalar, Kind::Config, |v| {
        refused_or(Dob::<T>::new(&nominal, v), dob_probe)
    });
    let dob = Dob::<T>::new(&nominal, 1e-4).unwrap();
    s.site(
        M,
        "Dob::update(acceleration_des)",
        scalar,
        Kind::Kernel,
        |v| {
            let mut state = DobState::at(T::ZERO);
            let out = dob.update(&mut state, re::<T>(v), T::ZERO);
            finite([out.force_n, out.disturbance_n, state.estimate_n])
        },
    );
    s.site(M, "Dob::update(velocity)", scalar, Kind::Kernel, |v| {
        let mut state = DobState::at(T::ZERO);
        let out = dob.update(&mut state, T::ZERO, re::<T>(v));
        finite([out.force_n, out.disturbance_n, state.estimate_n])
    });
}

#[test]
fn bad_input_control() {
    sweep(|s| {
        control_sites::<f32>(s, "f32");
        control_sites::<f64>(s, "f64");
    });
}
