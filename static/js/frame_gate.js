// Whether a frame would show anything new. The robots move at the stream's rate, which
// is below the display's; the camera rests most of the time. A frame that would draw
// the same picture again costs a software renderer (SwiftShader, or the 2D view's
// Canvas) as much as any other, and the page's frame rate would count it as if it
// were news. So each animation frame takes a fingerprint of what the view shows and
// draws only when it differs from the last one drawn.

const GROW = 1024;
const CAMERA_TOLERANCE = 1e-9; // of a camera matrix entry (m, or a rotation's cosines)

/** How often an attribute was changed: its own count, or its interleaved buffer's (sprites). */
function versionOf( attribute ) {

	if ( ! attribute ) return - 1;
	return attribute.isInterleavedBufferAttribute ? attribute.data.version : attribute.version;

}

/**
 * The fingerprint of a scene as a camera sees it: the camera's matrices, and for
 * every visible object its id, world matrix, geometry (id, draw range, attribute
 * versions) and material (id, colour, opacity, visibility), written in traversal
 * order into one array and compared with the previous frame's, number by number.
 * Adding, removing, hiding, moving or recolouring anything, and a trail or box
 * whose points change, all change it. What it cannot see (the canvas size, renderer
 * settings) the stage reports with `invalidate()`.
 */
class FrameGate {

	constructor() {

		this._values = new Float64Array( GROW );
		this._length = 0;
		this._at = 0;
		this._changed = true;
		this._forced = true;
		this._visit = ( object ) => this._object( object );

	}

	/** The next call to `changed()` says true, whatever the scene (a resize, new settings). */
	invalidate() {

		this._forced = true;

	}

	/** Whether `scene` seen by `camera` differs from the last call; brings world matrices up to date. */
	changed( scene, camera ) {

		if ( scene.matrixWorldAutoUpdate ) scene.updateMatrixWorld();
		if ( camera.parent === null && camera.matrixWorldAutoUpdate ) camera.updateMatrixWorld();
		this._at = 0;
		this._changed = this._forced;
		this._forced = false;
		// OrbitControls moves a camera at rest by rounding errors every frame (its damping
		// decays geometrically, and the spherical round trip is not exact): far below a pixel.
		for ( const value of camera.matrixWorld.elements ) this._putNear( value );
		this._all( camera.projectionMatrix.elements );
		scene.traverseVisible( this._visit );
		if ( this._at !== this._length ) this._changed = true;
		this._length = this._at;
		return this._changed;

	}

	_object( object ) {

		this._put( object.id );
		this._all( object.matrixWorld.elements );
		const geometry = object.geometry;
		if ( geometry ) {

			this._put( geometry.id );
			this._put( geometry.drawRange.start );
			this._put( geometry.drawRange.count );
			this._put( versionOf( geometry.attributes.position ) );
			this._put( versionOf( geometry.index ) );

		}
		const material = object.material;
		if ( material ) for ( const one of Array.isArray( material ) ? material : [ material ] ) this._material( one );

	}

	_material( material ) {

		this._put( material.id );
		this._put( material.version ); // three counts needsUpdate
		this._put( material.visible ? material.opacity : - 1 );
		const color = material.color;
		if ( color ) {

			this._put( color.r );
			this._put( color.g );
			this._put( color.b );

		}
		if ( material.map ) {

			this._put( material.map.id );
			this._put( material.map.version ); // a canvas redrawn (a label's text)

		}

	}

	_all( numbers ) {

		for ( let i = 0; i < numbers.length; i ++ ) this._put( numbers[ i ] );

	}

	// As _put, but a change smaller than CAMERA_TOLERANCE (relative, or absolute below 1) is none.
	_putNear( value ) {

		const kept = this._values[ this._at ];
		if ( this._at < this._length && Math.abs( value - kept ) <= CAMERA_TOLERANCE * Math.max( 1, Math.abs( kept ) ) ) this._at ++;
		else this._put( value );

	}

	_put( value ) {

		if ( this._at === this._values.length ) {

			const more = new Float64Array( this._values.length + GROW );
			more.set( this._values );
			this._values = more;

		}
		if ( this._values[ this._at ] !== value ) {

			this._values[ this._at ] = value;
			this._changed = true;

		}
		this._at ++;

	}

}

export { FrameGate };
