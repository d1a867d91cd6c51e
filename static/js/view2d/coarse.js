import * as THREE from 'three';
import { GLTFLoader } from 'three/addons/loaders/GLTFLoader.js';

// The 2D view draws every link from its coarse mesh: the same GLB decimated by the
// server to a few hundred triangles (server/coarse, `?detail=coarse`), a flat colour per
// part. Each is fetched once per mesh URL, whatever the number of robots, ghosts and
// views using it.

const _toRoot = new THREE.Matrix4();
const _v = new THREE.Vector3();

/**
 * A coarse mesh ready to draw: its parts' triangles in the frame of the link mesh's
 * root (the link frame), `{ positions: Float32Array (x, y, z per vertex),
 * index: Uint32Array (3 per triangle), color: THREE.Color (linear), opacity }`.
 */
function flatten( root ) {

	root.updateWorldMatrix( true, true );
	_toRoot.copy( root.matrixWorld ).invert();
	const parts = [];
	root.traverse( ( child ) => {

		if ( ! child.isMesh ) return;
		const source = child.geometry.attributes.position;
		const positions = new Float32Array( source.count * 3 );
		const matrix = new THREE.Matrix4().multiplyMatrices( _toRoot, child.matrixWorld );
		for ( let i = 0; i < source.count; i ++ ) _v.fromBufferAttribute( source, i ).applyMatrix4( matrix ).toArray( positions, i * 3 );
		const index = child.geometry.index
			? Uint32Array.from( child.geometry.index.array )
			: Uint32Array.from( { length: source.count }, ( _, i ) => i );
		const material = Array.isArray( child.material ) ? child.material[ 0 ] : child.material;
		parts.push( { positions, index, color: material.color.clone(), opacity: material.transparent ? material.opacity : 1 } );

	} );
	return parts;

}

/** Coarse meshes by the URL of the full one: `get(url)` is the parts, or null until they are in. */
class CoarseMeshes {

	constructor( onArrival ) {

		this.onArrival = onArrival; // () => void: something new to draw
		this._loader = new GLTFLoader();
		this._entries = new Map(); // full mesh URL -> { parts | null, failed }

	}

	/** The parts of `url`'s coarse mesh; null while it loads or where it has none (`failed(url)`). */
	get( url ) {

		let entry = this._entries.get( url );
		if ( entry === undefined ) {

			entry = { parts: null, failed: false };
			this._entries.set( url, entry );
			const coarse = new URL( url, window.location.href );
			coarse.searchParams.set( 'detail', 'coarse' );
			this._loader.loadAsync( coarse.href ).then( ( gltf ) => {

				entry.parts = flatten( gltf.scene );

			}, ( err ) => {

				// Drawn from its full mesh instead: slower, but drawn.
				console.warn( `linkview: no coarse mesh for ${url}; the 2D view draws the full one`, err );
				entry.failed = true;

			} ).finally( () => this.onArrival() );

		}
		return entry.parts;

	}

	/** How many coarse meshes are still on their way. */
	get pending() {

		let count = 0;
		for ( const entry of this._entries.values() ) if ( entry.parts === null && ! entry.failed ) count ++;
		return count;

	}

	/** Whether `url` has no coarse mesh (the server could not make one). */
	failed( url ) {

		return this._entries.get( url )?.failed === true;

	}

}

export { CoarseMeshes };
