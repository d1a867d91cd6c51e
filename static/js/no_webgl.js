// For a browser without WebGL (switched off by policy, a remote desktop, an old GPU
// driver): the page keeps everything that needs no 3D, cards, readouts, plots, sources,
// simulation, live. The scene is still built, so every module works as usual; it is
// just never drawn.

/** Whether this browser can make a WebGL context at all (asked once, on a scratch canvas). */
function hasWebGL() {

	try {

		const probe = document.createElement( 'canvas' );
		return Boolean( probe.getContext( 'webgl2' ) || probe.getContext( 'webgl' ) );

	} catch {

		return false;

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

export { NoRenderer, hasWebGL };
