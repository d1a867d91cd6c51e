import * as THREE from 'three';

/**
 * A sprite showing a 2D canvas, drawn over the robots (no depth test) at a constant
 * size on screen (sizeAttenuation off): text in the view that costs no DOM work per
 * frame. Returns { canvas, ctx, texture, sprite }; draw on `ctx`, then set
 * `texture.needsUpdate`.
 */
function canvasSprite() {

	const canvas = document.createElement( 'canvas' );
	// On the CPU: the 2D view draws this canvas into its own every frame, and reading an
	// accelerated one back from SwiftShader's GPU process took ~0.2 s a letter there
	// (2 frames/s in Chromium's default path; WebGL uploads it once either way).
	const ctx = canvas.getContext( '2d', { willReadFrequently: true } );
	const texture = new THREE.CanvasTexture( canvas );
	texture.colorSpace = THREE.SRGBColorSpace;
	const material = new THREE.SpriteMaterial( { map: texture, sizeAttenuation: false, depthTest: false, depthWrite: false, toneMapped: false } );
	return { canvas, ctx, texture, sprite: new THREE.Sprite( material ) };

}

export { canvasSprite };
