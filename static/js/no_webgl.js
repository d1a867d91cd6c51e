// For a browser without WebGL (switched off by policy, a remote desktop, an old GPU
// driver): the page keeps everything that needs no 3D, cards, readouts, plots, sources,
// simulation, live. The scene is still built, so every module works as usual; it is
// just never drawn.

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

/** What the Stage uses of a THREE.WebGLRenderer, drawing nothing: animation frames still run. */
class NoRenderer {

	constructor() {

		this.domElement = document.createElement( 'div' );
		this.domElement.className = 'no-webgl-view';
		this.shadowMap = { enabled: false, type: 0 };
		this.toneMapping = 0;
		this.info = { render: { calls: 0, triangles: 0, lines: 0 } };
		this._frame = 0;
		this._loop = null;

	}

	setAnimationLoop( loop ) {

		this._loop = loop;
		cancelAnimationFrame( this._frame );
		if ( ! loop ) return;
		const step = ( time ) => {

			this._frame = requestAnimationFrame( step );
			this._loop( time );

		};
		this._frame = requestAnimationFrame( step );

	}

	setPixelRatio() {}

	setSize() {}

	render() {}

	dispose() {

		this.setAnimationLoop( null );

	}

}

export { NoRenderer, probeWebGL };
