//! The shader snippets compile: GLSL and WGSL through naga's front ends and validator (the GLSL
//! is also executed in Mesa by tests/test_shader.py; the HLSL is compiled there by glslang).

use spheremap::jobs::shader::{snippet, WHATS};

/// A fragment shader calling every function of the snippet. naga's GLSL front end does not
/// take combined `sampler2D` uniforms (OpenGL's), so the one function that samples the map,
/// `sphere_map_lookup`, is left out here; glslang compiles it whole (tests/test_shader.py) and
/// Mesa runs it.
fn glsl_main(what: &str) -> String {
    let call = match what {
        "texgen" => "o = vec4(sphere_map_texgen(v_pos, v_nrm), 0.0, 1.0);",
        "lookup" => "o = vec4(sphere_map_st(v_nrm), 0.0, 1.0);",
        _ => "o = vec4(matcap_classic(v_nrm) + matcap_threejs(v_nrm, v_pos) + matcap_perspective(v_nrm, v_pos), 0.0, 1.0);",
    };
    format!(
        "#version 450\nlayout(location = 0) in vec3 v_pos;\nlayout(location = 1) in vec3 v_nrm;\n\
         layout(location = 0) out vec4 o;\n{}\nvoid main() {{ {call} }}\n",
        snippet("glsl", what)
            .unwrap()
            .split("\n// The environment seen")
            .next()
            .unwrap()
    )
}

fn wgsl_main(what: &str) -> String {
    let call = match what {
        "texgen" => "return vec4<f32>(sphere_map_texgen(p, n), 0.0, 1.0);",
        "lookup" => "return sphere_map_lookup(env, samp, p, n) + vec4<f32>(sphere_map_st(n), 0.0, 0.0);",
        _ => "return vec4<f32>(matcap_classic(n) + matcap_threejs(n, p) + matcap_perspective(n, p), 0.0, 1.0);",
    };
    format!(
        "{}\n@group(0) @binding(0) var env: texture_2d<f32>;\n@group(0) @binding(1) var samp: sampler;\n\
         @fragment\nfn main(@location(0) p: vec3<f32>, @location(1) n: vec3<f32>) -> @location(0) vec4<f32> {{ {call} }}\n",
        snippet("wgsl", what).unwrap()
    )
}

fn validate(module: &naga::Module) {
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(module)
    .unwrap_or_else(|e| panic!("{e:?}"));
}

#[test]
fn glsl_snippets_compile() {
    for what in WHATS {
        let src = glsl_main(what);
        let mut front = naga::front::glsl::Frontend::default();
        let opts = naga::front::glsl::Options::from(naga::ShaderStage::Fragment);
        let module = front
            .parse(&opts, &src)
            .unwrap_or_else(|e| panic!("{what}: {}", e.emit_to_string(&src)));
        validate(&module);
    }
}

#[test]
fn wgsl_snippets_compile() {
    for what in WHATS {
        let src = wgsl_main(what);
        let module = naga::front::wgsl::parse_str(&src)
            .unwrap_or_else(|e| panic!("{what}: {}", e.emit_to_string(&src)));
        validate(&module);
    }
}

#[test]
fn unknown_names_are_errors() {
    assert!(snippet("msl", "texgen").is_err());
    assert!(snippet("glsl", "shade").is_err());
}
