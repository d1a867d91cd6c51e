// For a browser without WebGL (switched off by policy, a remote desktop, an old GPU
// driver, Chrome without its SwiftShader fallback): the stage draws the same scene with
// Canvas 2D instead (view2d/), and everything else works as usual.

// SwiftShader (Chromium without a usable GPU), llvmpipe (Mesa), Microsoft's WARP:
// WebGL drawn by the CPU, where every pixel and draw call counts.
const SOFTWARE_RENDERERS = /swiftshader|llvmpipe|softpipe|software|warp/i;

/**
 * What draws this browser's WebGL, asked once on a scratch canvas: `null` when it
 * has none, else `{ name, software }` (`software`: a CPU rasteriser, as far as
 * the browser tells its name).
 */
function probeWebGL() {

	try {

		const probe = document.createElement( 'canvas' );
		const gl = probe.getContext( 'webgl2' ) || probe.getContext( 'webgl' );
		if ( ! gl ) return null;
		const info = gl.getExtension( 'WEBGL_debug_renderer_info' );
		const name = String( gl.getParameter( info ? info.UNMASKED_RENDERER_WEBGL : gl.RENDERER ) );
		gl.getExtension( 'WEBGL_lose_context' )?.loseContext(); // one context less to keep
		return { name, software: SOFTWARE_RENDERERS.test( name ) };

	} catch {

		return null;

	}

}

export { probeWebGL };
