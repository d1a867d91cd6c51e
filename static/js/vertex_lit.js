import * as THREE from 'three';

// The lowest quality level's material: Lambert lighting computed per vertex, not
// per pixel. Software WebGL pays per pixel; the robots' Lambert shading was a
// third of the page's WebGL time with `--disable-gpu` (bench/page_fps.py).
// Lambert light depends only on the normal, and the simplified meshes' normals
// are nearly flat per triangle, so shading at the vertices and interpolating
// looks the same.

const VERTEX = /* glsl */ `
#include <common>
#include <lights_pars_begin>
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
	vOutgoing = irradiance * color * RECIPROCAL_PI; // three's BRDF_Lambert
	gl_Position = projectionMatrix * modelViewMatrix * vec4( position, 1.0 );
}
`;

const FRAGMENT = /* glsl */ `
varying vec3 vOutgoing;
void main() {
	gl_FragColor = vec4( vOutgoing, 1.0 );
	#include <tonemapping_fragment>
	#include <colorspace_fragment>
}
`;

/** Lambert shading of vertex colours (the `color` attribute), lit at the vertices. */
function vertexLitMaterial() {

	return new THREE.ShaderMaterial( {
		uniforms: THREE.UniformsUtils.clone( THREE.UniformsLib.lights ),
		vertexShader: VERTEX,
		fragmentShader: FRAGMENT,
		vertexColors: true,
		lights: true,
	} );

}

export { vertexLitMaterial };
