import * as THREE from 'three';

// The lowest quality level's material: Lambert lighting computed per vertex, not
// per pixel. Software WebGL pays per pixel; the robots' Lambert shading was a
// third of the page's WebGL time with `--disable-gpu` (bench/page_fps.py).
// Lambert light depends only on the normal, and the simplified meshes' normals
// are nearly flat per triangle, so shading at the vertices and interpolating
// looks the same. Tone mapping and the sRGB transfer are done at the vertices
// too (three's own functions): per pixel they cost a `pow` per channel, and the
// fragment shader is left with nothing to do but write the colour.

const VERTEX = /* glsl */ `
#include <common>
#include <lights_pars_begin>
#include <tonemapping_pars_fragment>
#include <colorspace_pars_fragment>
varying vec3 vOutgoing;
void main() {
	vec3 n = normalize( normalMatrix * normal );
	vec3 irradiance = ambientLightColor;
#if NUM_HEMI_LIGHTS > 0
	for ( int i = 0; i < NUM_HEMI_LIGHTS; i ++ ) irradiance += getHemisphereLightIrradiance( hemisphereLights[ i ], n );
#endif
#if NUM_DIR_LIGHTS > 0
	for ( int i = 0; i < NUM_DIR_LIGHTS; i ++ ) irradiance += saturate( dot( n, directionalLights[ i ].direction ) ) * directionalLights[ i ].color;
#endif
	vec3 outgoing = irradiance * color * RECIPROCAL_PI; // three's BRDF_Lambert
	vOutgoing = sRGBTransferOETF( vec4( NeutralToneMapping( outgoing ), 1.0 ) ).rgb;
	gl_Position = projectionMatrix * modelViewMatrix * vec4( position, 1.0 );
}
`;

const FRAGMENT = /* glsl */ `
varying vec3 vOutgoing;
void main() {
	gl_FragColor = vec4( vOutgoing, 1.0 );
}
`;

/**
 * Lambert shading of vertex colours (the `color` attribute), lit, tone mapped (neutral)
 * and encoded as sRGB at the vertices: the stage's renderer settings (scene.js).
 */
function vertexLitMaterial() {

	return new THREE.ShaderMaterial( {
		uniforms: THREE.UniformsUtils.clone( THREE.UniformsLib.lights ),
		vertexShader: VERTEX,
		fragmentShader: FRAGMENT,
		vertexColors: true,
		lights: true,
		toneMapped: false, // done in the vertex shader
	} );

}

export { vertexLitMaterial };
